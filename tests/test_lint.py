"""Ruff (lint with the D and T20 rules, and format) and mypy over the package, as STYLE.md asks."""

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def run(*args):
    return subprocess.run([sys.executable, "-m", *args], cwd=ROOT, capture_output=True, text=True)


def test_ruff_clean():
    proc = run("ruff", "check", ".")
    assert proc.returncode == 0, proc.stdout + proc.stderr


def test_ruff_format_clean():
    proc = run("ruff", "format", "--check", "service", "tests", "bench", "testbed")
    assert proc.returncode == 0, proc.stdout + proc.stderr


def test_mypy_clean():
    proc = run("mypy")
    assert proc.returncode == 0, proc.stdout + proc.stderr
