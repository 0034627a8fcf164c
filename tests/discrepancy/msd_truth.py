"""Records of the msd's equations with left-out physics, solved by scipy (not by the FMU).

m x'' + b x' + k x + cubic x^3 = f + offset, x measured with Gaussian noise, f a sum of eight
sines drawn from the seed.
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

from fmuid.data import Experiment, experiment_from_arrays, spec_from_json

M, K, B, SIGMA = 1.1, 4.4, 1.6, 0.005

SPEC = spec_from_json(
    '{"parameters": {"m": {"start": 1, "lower": 0.1, "upper": 10},'
    ' "k": {"start": 4, "lower": 0.1, "upper": 20}, "b": {"start": 1, "lower": 0.1,'
    ' "upper": 10}}, "inputs": ["f"], "outputs": {"x": {"sigma": 0.005}}, "seed": 0,'
    ' "global_search": false}'
)
"""The textbook msd's spec: m, k, b free, x measured with the records' noise."""


def msd_record(name: str, seed: int, offset: float, cubic: float) -> Experiment:
    """Return 30 s of the msd driven by a multisine, with an input offset and a cubic spring."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, 30.0, 0.05)
    freqs, phases = rng.uniform(0.1, 1.5, 8), rng.uniform(0.0, 2 * np.pi, 8)
    u = 0.6 * sum(np.sin(2 * np.pi * f * t + p) for f, p in zip(freqs, phases))

    def rhs(tt: float, s: np.ndarray) -> list[float]:
        x, v = s
        return [v, (np.interp(tt, t, u) + offset + cubic * x**3 - B * v - K * x) / M]

    sol = solve_ivp(rhs, (0.0, t[-1]), [0.0, 0.0], t_eval=t, rtol=1e-10, atol=1e-12, max_step=0.01)
    x = sol.y[0] + rng.normal(0.0, SIGMA, t.size)
    return experiment_from_arrays(name, t, {"f": u, "x": x})
