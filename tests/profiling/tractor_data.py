"""Simulated tractor datasets of thesis 3.2.3.1 for the engine tests."""

import json

import numpy as np

from fmuid.data import experiment_from_arrays, spec_from_json
from fmuid.model.simulator import Simulator

TIRES = {
    "C_atf": (220000.0, 10000.0, 700000.0),
    "C_atr": (486000.0, 10000.0, 700000.0),
    "C_air": (167000.0, 10000.0, 700000.0),
    "sig_tf": (0.5, 0.1, 2.0),
    "sig_tr": (1.0, 0.1, 2.0),
    "sig_ir": (0.5, 0.1, 2.0),
}


def ramp_dataset(fmu, snr, seed, rate=5.0, duration=10.0):
    """Ramp steer (0 until 1 s, 0.17452 rad at 1.5 s), yaw rates with noise max|gam_t|/SNR."""
    t = np.arange(0.0, duration + 1e-9, 1.0 / rate)
    corners_t = np.array([0.0, 1.0, 1.5, duration])
    corners_u = np.array([0.0, 0.0, 0.17452, 0.17452])
    y = Simulator(fmu).simulate({}, corners_t, {"delta": corners_u}, t, ["gam_t", "gam_i"])
    sigma = np.max(np.abs(y[:, 0])) / snr
    rng = np.random.default_rng(seed)
    noisy = y + rng.normal(0.0, sigma, y.shape)
    # The steer corners are rows of their own (outputs empty) so the ramp is exact.
    rows = np.union1d(t, corners_t)
    sampled = np.isin(rows, t)
    columns = {"delta": np.interp(rows, corners_t, corners_u)}
    for j, name in enumerate(("gam_t", "gam_i")):
        col = np.full(rows.size, np.nan)
        col[sampled] = noisy[:, j]
        columns[name] = col
    return experiment_from_arrays("ramp.csv", rows, columns), sigma


def tire_spec(sigma, global_search=False, seed=0):
    body = {
        "parameters": {
            n: {"start": v, "lower": lo, "upper": hi} for n, (v, lo, hi) in TIRES.items()
        },
        "inputs": ["delta"],
        "outputs": {"gam_t": {"sigma": sigma}, "gam_i": {"sigma": sigma}},
        "confidence": 0.68,
        "global_search": global_search,
        "seed": seed,
    }
    return spec_from_json(json.dumps(body))
