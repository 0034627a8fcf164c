"""Independent references written from the printed thesis equations (no fmuid code).

Tractor-implement: eqs. 3.3-3.18 in the matrix form M X' = N X + P delta (eqs. 3.11-3.14),
plus the documented extra physics (tire saturation, side slope), integrated by scipy's
``solve_ivp`` piecewise between the input breakpoints with the same piecewise-linear input.
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp
from scipy.linalg import expm

NOMINAL = {
    "C_atf": 220000.0,
    "C_atr": 486000.0,
    "C_air": 167000.0,
    "sig_tf": 0.5,
    "sig_tr": 1.0,
    "sig_ir": 0.5,
    "m_t": 9391.0,
    "m_i": 2127.0,
    "I_tz": 35709.0,
    "I_iz": 6402.0,
    "u_tc": 4.5,
    "a": 1.7,
    "b": 1.2,
    "c": 2.1,
    "d": 3.62,
    "e": 0.1,
}

# Table 3.2 bounds of the six tire parameters.
BOUNDS = {
    "C_atf": (10000.0, 700000.0),
    "C_atr": (10000.0, 700000.0),
    "C_air": (10000.0, 700000.0),
    "sig_tf": (0.1, 2.0),
    "sig_tr": (0.1, 2.0),
    "sig_ir": (0.1, 2.0),
}

OUTPUTS = ("gam_t", "gam_i", "psi_t", "psi_i", "v_tc", "x_tc", "y_tc", "x_ic", "y_ic")
RAMP_TIME = np.array([0.0, 1.0, 1.5, 10.0])
RAMP_DELTA = np.array([0.0, 0.0, 0.17452, 0.17452])
CHIRP_TIME = np.round(np.arange(101) * 0.1, 10)
CHIRP_DELTA = 0.17453 * np.sin(2 * np.pi * (0.1 * CHIRP_TIME + 0.02 * CHIRP_TIME**2))
OUTPUT_TIME = np.round(np.arange(51) * 0.2, 10)


def tractor_matrices(p: dict[str, float]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """M, N, P of eqs. 3.12-3.14."""
    mt, mi, it, ii, u = p["m_t"], p["m_i"], p["I_tz"], p["I_iz"], p["u_tc"]
    a, b, c, d, e = p["a"], p["b"], p["c"], p["d"], p["e"]
    cf, cr, ci = p["C_atf"], p["C_atr"], p["C_air"]
    sf, sr, si = p["sig_tf"], p["sig_tr"], p["sig_ir"]
    m = np.eye(8)
    m[:3, :3] = [
        [mt + mi, -mi * c, -mi * d],
        [-mi * c, it + mi * c**2, mi * c * d],
        [-mi * d, mi * c * d, ii + mi * d**2],
    ]
    n = np.array(
        [
            [0, -(mt + mi) * u, 0, -cf, -cr, -ci, 0, 0],
            [0, mi * c * u, 0, -a * cf, b * cr, c * ci, 0, 0],
            [0, mi * d * u, 0, 0, 0, (d + e) * ci, 0, 0],
            [1 / sf, a / sf, 0, -u / sf, 0, 0, 0, 0],
            [1 / sr, -b / sr, 0, 0, -u / sr, 0, 0, 0],
            [1 / si, -c / si, -(d + e) / si, 0, 0, -u / si, u / si, -u / si],
            [0, 1, 0, 0, 0, 0, 0, 0],
            [0, 0, 1, 0, 0, 0, 0, 0],
        ]
    )
    pvec = np.array([0, 0, 0, -u / sf, 0, 0, 0, 0])
    return m, n, pvec


def tractor_reference(
    params: dict[str, float],
    input_time: np.ndarray,
    input_delta: np.ndarray,
    output_time: np.ndarray,
    alpha_sat: float = 0.0,
    slope: float = 0.0,
) -> dict[str, np.ndarray]:
    """Solve the tractor model with solve_ivp (DOP853, rtol 1e-10, atol 1e-12)."""
    p = {**NOMINAL, **params}
    m, n, pvec = tractor_matrices(p)
    m_inv = np.linalg.inv(m)
    stiffness = {3: p["C_atf"], 4: p["C_atr"], 5: p["C_air"]}
    u, c, d = p["u_tc"], p["c"], p["d"]
    weight_t = p["m_t"] * 9.81 * np.sin(slope)
    weight_i = p["m_i"] * 9.81 * np.sin(slope)

    def rhs(t: float, s: np.ndarray, delta0: float, rate: float, t0: float) -> np.ndarray:
        x = s[:8]
        force = n @ x + pvec * (delta0 + rate * (t - t0))
        if alpha_sat > 0:
            for j, cj in stiffness.items():
                saturated = -cj * alpha_sat * np.tanh(x[j] / alpha_sat)
                force[:3] += n[:3, j] / (-cj) * (saturated + cj * x[j])
        if slope != 0:
            f_t = weight_t * np.cos(x[6])
            f_i = weight_i * np.cos(x[7])
            force[:3] += [f_t + f_i, -c * f_i, -d * f_i]
        out = np.empty(10)
        out[:8] = m_inv @ force
        out[8] = u * np.cos(x[6]) - x[0] * np.sin(x[6])
        out[9] = u * np.sin(x[6]) + x[0] * np.cos(x[6])
        return out

    breaks = np.unique(np.concatenate([input_time, [output_time[-1]]]))
    breaks = breaks[breaks <= output_time[-1]]
    state = np.zeros(10)
    states = np.empty((output_time.size, 10))
    states[output_time == breaks[0]] = state
    for t0, t1 in zip(breaks[:-1], breaks[1:], strict=True):
        j = min(np.searchsorted(input_time, t0, side="right") - 1, input_time.size - 2)
        rate = (input_delta[j + 1] - input_delta[j]) / (input_time[j + 1] - input_time[j])
        delta0 = input_delta[j] + rate * (t0 - input_time[j])
        mask = (output_time > t0) & (output_time <= t1)
        t_eval = np.unique(np.append(output_time[mask], t1))
        sol = solve_ivp(
            rhs,
            (t0, t1),
            state,
            method="DOP853",
            rtol=1e-10,
            atol=1e-12,
            t_eval=t_eval,
            args=(delta0, rate, t0),
        )
        assert sol.success, sol.message
        states[mask] = sol.y.T[np.searchsorted(t_eval, output_time[mask])]
        state = sol.y[:, -1]
    v, gt, gi, pt, pi, xt, yt = (states[:, k] for k in (0, 1, 2, 6, 7, 8, 9))
    return {
        "v_tc": v,
        "gam_t": gt,
        "gam_i": gi,
        "psi_t": pt,
        "psi_i": pi,
        "x_tc": xt,
        "y_tc": yt,
        "x_ic": xt - c * np.cos(pt) - d * np.cos(pi),
        "y_ic": yt - c * np.sin(pt) - d * np.sin(pi),
    }


def tractor_yaw_rates_exact(
    params: dict[str, float],
    input_time: np.ndarray,
    input_delta: np.ndarray,
    output_time: np.ndarray,
) -> dict[str, np.ndarray]:
    """Yaw rates of the linear model (no extra physics) by the exact matrix exponential.

    Between breakpoints the steer is linear in time, so the state ``x`` with the steer ``u`` and
    its slope ``r`` appended obeys ``s' = F s`` with constant ``F``, and ``expm(F h)`` steps it
    exactly. The same answer as :func:`tractor_reference` (to ~1e-10) in a fraction of its time.
    """
    m, n, pvec = tractor_matrices({**NOMINAL, **params})
    m_inv = np.linalg.inv(m)
    f = np.zeros((10, 10))
    f[:8, :8] = m_inv @ n
    f[:8, 8] = m_inv @ pvec
    f[8, 9] = 1.0
    steps: dict[float, np.ndarray] = {}
    grid = np.unique(np.concatenate([input_time, output_time]))
    grid = grid[grid <= output_time[-1]]
    state = np.zeros(10)
    states = {float(grid[0]): state[:8]}
    for t0, t1 in zip(grid[:-1], grid[1:], strict=True):
        j = min(np.searchsorted(input_time, t0, side="right") - 1, input_time.size - 2)
        rate = (input_delta[j + 1] - input_delta[j]) / (input_time[j + 1] - input_time[j])
        state[8] = input_delta[j] + rate * (t0 - input_time[j])
        state[9] = rate
        h = round(float(t1 - t0), 12)
        if h not in steps:
            steps[h] = expm(f * h)
        state = steps[h] @ state
        states[float(t1)] = state[:8]
    x = np.array([states[float(t)] for t in output_time])
    return {"gam_t": x[:, 1], "gam_i": x[:, 2]}
