"""Shared helpers of the data tests."""

from __future__ import annotations

from pathlib import Path


def write_csv(directory: Path, text: str | bytes, name: str = "step.csv") -> Path:
    """Write a CSV file (text as UTF-8, bytes as given) and return its path."""
    path = directory / name
    if isinstance(text, bytes):
        path.write_bytes(text)
    else:
        path.write_text(text, encoding="utf-8", newline="")
    return path
