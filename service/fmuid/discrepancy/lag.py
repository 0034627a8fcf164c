"""The exact first-order lag of a piecewise-linear signal (input and output lags, the testbed)."""

from __future__ import annotations

import numpy as np
from scipy.signal import lfilter


def first_order_lag(time: np.ndarray, values: np.ndarray, tau: float) -> np.ndarray:
    """Exact first-order lag ``y' = (u - y) / tau`` of a piecewise-linear ``u``, from rest at u[0].

    Parameters
    ----------
    time
        Sample times [s], increasing.
    values
        Samples of ``u`` (first axis along time); ``u`` is linear between them.
    tau
        Time constant [s], > 0.

    """
    h = np.diff(time)
    u = np.asarray(values, dtype=float)
    if len(h) and np.allclose(h, h[0], rtol=1e-6):
        a = float(np.exp(-h[0] / tau))
        b0 = 1.0 - tau / h[0] * (1.0 - a)
        return u[0] + lfilter([b0, 1.0 - a - b0], [1.0, -a], u - u[0], axis=0)
    a_k = np.exp(-h / tau)
    ramp = 1.0 - tau / h * (1.0 - a_k)
    y = np.empty_like(u)
    y[0] = u[0]
    for k in range(len(h)):
        y[k + 1] = a_k[k] * y[k] + (1.0 - a_k[k]) * u[k] + ramp[k] * (u[k + 1] - u[k])
    return y
