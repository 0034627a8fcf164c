"""A tractor study on disk, for command-line runs: d.csv (design 1, SNR 25) and s.json."""

import json
from pathlib import Path

import numpy as np

from fmuid.demo.thesis import BOUNDS, DESIGNS, NOMINAL, OUTPUTS, simulate_dataset


def tractor_study(folder: Path, tractor_fmu: Path) -> list[str]:
    """Write d.csv (design 1, SNR 25) and s.json (six tire parameters); return CLI arguments."""
    exp, sigma = simulate_dataset(tractor_fmu, DESIGNS[0], 25.0, np.random.default_rng(1))
    names = list(exp.columns)
    rows = [",".join(["time", *names])]
    for i, t in enumerate(exp.time):
        cells = [
            "" if np.isnan(exp.columns[n][i]) else repr(float(exp.columns[n][i])) for n in names
        ]
        rows.append(",".join([repr(float(t)), *cells]))
    (folder / "d.csv").write_text("\n".join(rows) + "\n")
    spec = {
        "parameters": {
            n: {"start": NOMINAL[n], "lower": BOUNDS[n][0], "upper": BOUNDS[n][1]} for n in NOMINAL
        },
        "inputs": ["delta"],
        "outputs": {o: {"sigma": sigma} for o in OUTPUTS},
        "global_search": False,
    }
    (folder / "s.json").write_text(json.dumps(spec))
    return ["--fmu", str(tractor_fmu), "--data", "d.csv", "--spec", "s.json", "--out", "r.json"]
