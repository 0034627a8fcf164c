"""The command line on bad inputs not covered by ``tests/cli``: exit 2, the problem named on
stderr, no traceback, no result file."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from test_bad_inputs import million_rows, model_exchange_only, with_parameter

from api_helpers import member, msd_spec, rewrite_fmu
from fmuid.cli import main

GOOD_CSV = b"time,f,x\n0,40,0\n0.2,40,0.1\n0.4,40,0.3\n"


def run_fit(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], fmu: Path, csv: bytes, spec: str
) -> str:
    data = tmp_path / "bad.csv"
    data.write_bytes(csv)
    spec_file = tmp_path / "spec.json"
    spec_file.write_text(spec)
    out = tmp_path / "r.json"
    args = ["fit", "--fmu", fmu, "--data", data, "--spec", spec_file, "--out", out]
    code = main([str(a) for a in args])
    err = capsys.readouterr().err
    assert code == 2, err
    assert "Traceback" not in err
    assert not out.exists()
    return err


@pytest.mark.parametrize(
    ("csv", "spec", "needles"),
    [
        (b"", msd_spec(), ["bad.csv", "empty"]),
        (b"f,x\n40,0\n40,0.1\n", msd_spec(), ["bad.csv", "time"]),
        (b"time,f,x\n0,40,0\n0.2,40,inf\n", msd_spec(), ["bad.csv", "row 3", "inf"]),
        (million_rows(), msd_spec(), ["bad.csv", "200000 data rows"]),
        (GOOD_CSV, with_parameter("k", start=20.0, lower=0.01, upper=10.0), ["k", "start"]),
        (GOOD_CSV, with_parameter("m", start=1.1, lower=5.0, upper=1.0), ["m", "lower"]),
    ],
    ids=["empty", "no-time", "inf", "million-rows", "start-outside", "lower>upper"],
)
def test_bad_data_or_spec(msd_file, tmp_path, capsys, csv, spec, needles):
    err = run_fit(tmp_path, capsys, msd_file, csv, spec)
    assert all(needle in err for needle in needles), err


def fmi3(msd: Path, target: Path) -> Path:
    xml = member(msd, "modelDescription.xml").replace(b'fmiVersion="2.0"', b'fmiVersion="3.0"')
    return rewrite_fmu(msd, target, {"modelDescription.xml": xml})


@pytest.mark.parametrize(
    ("make", "needle"),
    [
        (lambda msd, target: target.write_bytes(b"hello") and target, "zip"),
        (fmi3, "3.0"),
        (model_exchange_only, "model exchange"),
        (lambda msd, t: rewrite_fmu(msd, t, {"binaries/linux64/msd.so": None}), "linux64"),
        (
            lambda msd, t: rewrite_fmu(msd, t, {"binaries/linux64/msd.so": b"\x7fELF junk"}),
            "msd.so",
        ),
    ],
    ids=["not-a-zip", "fmi3", "model-exchange", "no-linux64", "binary-not-loading"],
)
def test_bad_fmu(msd_file, tmp_path, capsys, make, needle):
    fmu = make(msd_file, tmp_path / "bad.fmu")
    err = run_fit(tmp_path, capsys, fmu, GOOD_CSV, json.dumps(json.loads(msd_spec())))
    assert "bad.fmu" in err and needle in err, err
