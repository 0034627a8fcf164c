"""A small msd study on disk: step.csv (40 N step solved by scipy, plus noise) and spec.json."""

import json
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

TRUTH = {"m": 1.1, "k": 4.4, "b": 1.6}
SIGMA = 0.05


def write_msd_study(folder: Path) -> None:
    """Write step.csv and spec.json (k and b free, m fixed) into ``folder``."""
    m, k, b = TRUTH.values()
    t = np.arange(0.0, 10.0 + 1e-9, 0.2)
    sol = solve_ivp(
        lambda _t, y: [y[1], (40.0 - b * y[1] - k * y[0]) / m],
        (0.0, 10.0),
        [0.0, 0.0],
        t_eval=t,
        rtol=1e-11,
        atol=1e-12,
    )
    x = sol.y[0] + np.random.default_rng(3).normal(0.0, SIGMA, t.size)
    np.savetxt(
        folder / "step.csv",
        np.column_stack([t, np.full(t.size, 40.0), x]),
        delimiter=",",
        header="time,f,x",
        comments="",
    )
    spec = {
        "parameters": {
            "k": {"start": 3.0, "lower": 0.1, "upper": 20.0},
            "b": {"start": 1.0, "lower": 0.1, "upper": 20.0},
        },
        "fixed": {"m": m},
        "inputs": ["f"],
        "outputs": {"x": {"sigma": SIGMA}},
        "global_search": False,
    }
    (folder / "spec.json").write_text(json.dumps(spec))
