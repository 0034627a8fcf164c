"""False-alarm rate of the residual whiteness test on fitted residuals of pure noise.

Each case is a series of ``n`` white samples less its projection on ``p`` smooth regressors
(sines of 0.3 to 3.3 cycles over the record: what a fit's sensitivities absorb). For each
choice of lags (``n // 5``, the lags before, and :func:`~fmuid.discrepancy.residual_tests.lb_lags`)
the table prints how many times more often than nominal the p-value falls below 1e-4, 1e-3
and 1e-2, with the asymptotic chi2(h) and with the moment calibration the diagnosis uses
(``null=`` of :func:`~fmuid.discrepancy.residual_tests.ljung_box`, 400 null draws).

``python bench/whiteness.py [--draws 100000]``
"""

from __future__ import annotations

import argparse

import numpy as np

from fmuid.discrepancy import residual_tests as rt
from fmuid.discrepancy.locate import NULL_DRAWS

CASES = ((40, 3), (101, 0), (101, 6), (500, 6))
"""(samples, smooth regressors) of each case."""

LEVELS = (1e-4, 1e-3, 1e-2)


def _projected(rng: np.random.Generator, draws: int, basis: np.ndarray, n: int) -> np.ndarray:
    e = rng.standard_normal((draws, n))
    return e - (e @ basis) @ basis.T


def main() -> None:
    """Print the table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--draws", type=int, default=100_000, help="series per case")
    args = parser.parse_args()
    rng = np.random.default_rng(5)
    print(
        f"{'n':>4} {'p':>2} {'lags':>5}  "
        + "  ".join(f"{'chi2 ' + f'{a:g}':>10}" for a in LEVELS)
        + "  "
        + "  ".join(f"{'calib ' + f'{a:g}':>11}" for a in LEVELS)
    )
    for n, p in CASES:
        t = np.linspace(0.0, 1.0, n)
        freqs, phases = np.array([0.3, 0.7, 1.1, 1.9, 2.5, 3.3])[:p], rng.uniform(0, 6, p)
        x = np.sin(2 * np.pi * np.outer(t, freqs) + phases) if p else np.zeros((n, 0))
        basis = np.linalg.qr(x)[0] if p else x
        series = _projected(rng, args.draws, basis, n)
        reference = _projected(rng, NULL_DRAWS, basis, n)
        for name, lags in (("n/5", max(1, min(20, n // 5))), ("used", rt.lb_lags(n))):
            q = rt.ljung_box_null(series, lags)
            null = rt.ljung_box_null(reference, lags)
            plain, _ = rt.whiteness_p(q, lags)
            calibrated, _ = rt.whiteness_p(q, lags, null)
            ratios = [np.mean(v < a) / a for v in (plain, calibrated) for a in LEVELS]
            print(
                f"{n:4d} {p:2d} {name:>5}  "
                + "  ".join(f"{r:10.1f}" for r in ratios[:3])
                + "  "
                + "  ".join(f"{r:11.1f}" for r in ratios[3:])
            )


if __name__ == "__main__":
    main()
