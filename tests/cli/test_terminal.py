"""What the terminal user sees: fmuid info, simulate options, tables, progress, help, Ctrl-C."""

import dataclasses
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from tests.profiling.test_interrupt import workers_of

from fmuid.cli import main
from fmuid.console import ProgressDisplay, profile_table
from fmuid.progress import Progress
from plots.toy import toy_profile_result
from tractor_files import tractor_study

REPO = Path(__file__).resolve().parents[2]


def run(args, capsys):
    code = main([str(a) for a in args])
    out = capsys.readouterr()
    return code, out.out, out.err


@pytest.fixture
def builtin_dir(monkeypatch, built_fmus):
    monkeypatch.setenv("FMUID_FMU_DIR", str(built_fmus["msd"].parent))


def test_info_lists_what_a_spec_needs(builtin_dir, capsys):
    table = json.loads((REPO / "model_src" / "msd" / "variables.json").read_text())["variables"]
    code, out, err = run(["info", "msd", "--json"], capsys)
    assert code == 0, err
    info = json.loads(out)
    assert (info["fmi_version"], info["interface"]) == ("2.0", "CoSimulation")
    by_causality = {
        c: [(v["name"], v["start"], v["unit"], v["description"]) for v in info[c + "s"]]
        for c in ("parameter", "input", "output")
    }
    for c, listed in by_causality.items():
        declared = [
            (v["name"], v.get("start"), v["unit"], v["description"])
            for v in table
            if v["causality"] == c
        ]
        assert listed == declared
    code, out, _ = run(["info", "msd"], capsys)
    assert code == 0
    assert "FMI 2.0, CoSimulation" in out
    assert "k     Real  N/m    4.4" in out
    code, _, err = run(["info", "tractor"], capsys)
    assert code == 2
    assert "built-in model" in err


def test_info_says_what_runs_at_the_start_values_showed(builtin_dir, leaky_reset_fmu, capsys):
    code, out, err = run(["info", "msd", "--json"], capsys)
    assert code == 0, err
    assert json.loads(out)["health"] == {
        "simulates": True,
        "deterministic": True,
        "reset_reliable": True,
        "horizon_s": [0.0, 10.0],
        "message": "",
        "ignored": [],
    }
    code, out, err = run(["info", leaky_reset_fmu], capsys)
    assert code == 0, err
    assert "its reset is UNRELIABLE" in out
    code, out, _ = run(["info", "msd", "--json", "--no-health"], capsys)
    assert json.loads(out)["health"] is None


def test_simulate_with_fixed_values_only_and_input_columns(builtin_dir, tmp_path, capsys):
    (tmp_path / "in.csv").write_text("time,f\n0,40\n1,40\n2,40\n")
    (tmp_path / "spec.json").write_text(json.dumps({"fixed": {"k": 2.0}}))
    out = tmp_path / "y.csv"
    args = ["simulate", "--fmu", "msd", "--data", tmp_path / "in.csv", "--out", out]
    code, _, err = run([*args, "--spec", tmp_path / "spec.json", "--with-inputs"], capsys)
    assert code == 0, err
    table = np.genfromtxt(out, delimiter=",", names=True)
    assert table.dtype.names == ("time", "f", "x", "v")
    assert np.all(table["f"] == 40.0)
    # closed form of 1.1 x'' + 1.6 x' + 2.0 x = 40 from rest
    wn, zeta = np.sqrt(2.0 / 1.1), 1.6 / (2 * np.sqrt(2.0 * 1.1))
    wd = wn * np.sqrt(1 - zeta**2)
    t = table["time"]
    x = 40 / 2.0 * (1 - np.exp(-zeta * wn * t) * (np.cos(wd * t) + zeta * wn / wd * np.sin(wd * t)))
    assert np.allclose(table["x"], x, atol=1e-8)
    (tmp_path / "bad.json").write_text(json.dumps({"fixed": {"kk": 2.0}}))
    code, _, err = run([*args, "--spec", tmp_path / "bad.json"], capsys)
    assert code == 2
    assert "kk" in err


def test_profile_table_has_header_level_units_and_open_ends():
    result = toy_profile_result()
    k = dataclasses.replace(result.parameters["k"], ci_simultaneous=(2.5, None))
    fit = dataclasses.replace(result.fit, units={"m": "kg", "k": "N/m"})
    result = dataclasses.replace(result, fit=fit, parameters={**result.parameters, "k": k})
    lines = profile_table(result).splitlines()
    assert lines[0].split() == [
        "parameter",
        "estimate",
        "unit",
        "68%",
        "simultaneous",
        "68%",
        "pointwise",
        "label",
    ]
    assert set(lines[1]) <= {"-", " "}
    assert lines[3].split()[:4] == ["k", "10", "N/m", "[2.5,"]
    assert lines[3].split()[4] == "open]"
    assert "null" not in "\n".join(lines)
    assert lines[-1].startswith("'open': ")
    k = dataclasses.replace(k, ci_simultaneous=(2.5, 40.0), ci_pointwise=(5.0, 20.0))
    closed = dataclasses.replace(result, parameters={"k": k})
    assert "open" not in profile_table(closed)


def test_progress_is_log_lines_off_a_terminal(caplog):
    caplog.set_level("INFO", logger="fmuid")
    with ProgressDisplay(tty=False) as show:
        for done in range(5):
            show(Progress("profile", done, 4, "k +"))
    # the first event and the final one; the others fall inside the 2 s throttle
    assert [r.getMessage() for r in caplog.records] == ["profile: 0/4 k +", "profile: 4/4 k +"]


def test_progress_bar_on_a_terminal(capsys):
    with ProgressDisplay(tty=True) as show:
        show(Progress("fit", 3, 10))
        show(Progress("profile", 10, 10, "done"))
        show(Progress("profile", 12, 30, "the walk ended early"))
        tasks = {t.description: (t.completed, t.total) for t in show._bar.tasks}
        assert tasks == {"fit": (3, 10), "profile": (12, 30)}
    # a finished stage shows a full bar
    assert [(t.completed, t.total) for t in show._bar.tasks] == [(10, 10), (30, 30)]


def test_help_and_version_are_for_users():
    proc = subprocess.run(
        [sys.executable, "-m", "fmuid.cli", "--help"], capture_output=True, text=True, check=True
    )
    assert "contract" not in proc.stdout and "``" not in proc.stdout
    assert "info" in proc.stdout
    proc = subprocess.run(
        [sys.executable, "-c", "import sys, fmuid.cli; print(sorted(sys.modules))"],
        capture_output=True,
        text=True,
        check=True,
    )
    # --help imports none of the heavy libraries
    assert not {"numpy", "scipy", "matplotlib", "fmpy"} & set(eval(proc.stdout))
    proc = subprocess.run(
        [sys.executable, "-m", "fmuid.cli", "--version"], capture_output=True, text=True
    )
    assert proc.stdout.strip() == "fmuid 0.1.0"


def _group_alive(pgid: int) -> bool:
    """Whether a process of the group still runs (a zombie waiting for init to reap it is dead)."""
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[2]) == pgid and fields[0] != "Z":
            return True
    return False


@pytest.mark.slow
def test_ctrl_c_ends_a_profile_with_130_and_leaves_no_process(tractor_fmu, tmp_path):
    args = tractor_study(tmp_path, tractor_fmu)
    proc = subprocess.Popen(
        [sys.executable, "-m", "fmuid.cli", "profile", *args, "--workers", "2"],
        cwd=tmp_path,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,  # its own process group, as a terminal's foreground job
    )
    assert proc.stderr is not None
    workers_of(proc)  # the pool's two workers run the profile's tasks (health probes, walks)
    os.killpg(proc.pid, signal.SIGINT)  # what Ctrl-C does: SIGINT to the whole group
    deadline = time.monotonic() + 2.0
    assert proc.wait(timeout=20) == 130
    assert "interrupted" in proc.stderr.read()
    while time.monotonic() < deadline and _group_alive(proc.pid):
        time.sleep(0.05)
    assert not _group_alive(proc.pid), "a worker process outlived Ctrl-C by 2 s"
    assert not (tmp_path / "r.json").exists()
