"""Profile-likelihood speed on the tractor model (thesis 3.2.3.1: ramp steer, 10 s).

Prints, for each ``--snr`` (default 1000 and 25; sampled at ``--rate`` Hz, noise from
``--seed``): wall time, FMU simulations, simulations per profile point against a plain
trust-region re-fit from scratch (the cost a profile point would have without warm starts), the
cost of the right-valley checks (the fit check from diverse starts and the checks at the CI
ends, included in the total), the re-fits spent locating the CI ends exactly, and the
simultaneous CIs with each profile's quality record. ``--reference NAME ...`` also compares
those parameters' pointwise and simultaneous ends with the exact crossings of
``tests/profiling/reference.py`` (brentq on multi-start scipy re-fits; slow). The hidden-style
low-SNR cases: ``--snr 25 12.5 --seed 0`` and ``--rate 10 --snr 16.67 --seed 0``.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import time
from pathlib import Path

import numpy as np

import fmuid
from fmuid.data import experiment_from_arrays, spec_from_json
from fmuid.demo import BOUNDS, NOMINAL
from fmuid.estimation.optimize import fit_problem
from fmuid.estimation.space import z_to_value
from fmuid.model.builtin import builtin_fmu
from fmuid.model.simulator import Simulator
from fmuid.stages import make_problem


def dataset(fmu, snr: float, seed: int, rate: float = 5.0):
    t = np.round(np.arange(int(round(10.0 * rate)) + 1) / rate, 10)
    ct, cu = np.array([0.0, 1.0, 1.5, 10.0]), np.array([0.0, 0.0, 0.17452, 0.17452])
    y = Simulator(fmu).simulate({}, ct, {"delta": cu}, t, ["gam_t", "gam_i"])
    sigma = float(np.max(np.abs(y[:, 0])) / snr)
    y = y + np.random.default_rng(seed).normal(0.0, sigma, y.shape)
    rows = np.union1d(t, ct)
    cols = {"delta": np.interp(rows, ct, cu)}
    for j, name in enumerate(("gam_t", "gam_i")):
        col = np.full(rows.size, np.nan)
        col[np.isin(rows, t)] = y[:, j]
        cols[name] = col
    spec = spec_from_json(
        json.dumps(
            {
                "parameters": {
                    n: {"start": v, "lower": BOUNDS[n][0], "upper": BOUNDS[n][1]}
                    for n, v in NOMINAL.items()
                },
                "inputs": ["delta"],
                "outputs": {"gam_t": {"sigma": sigma}, "gam_i": {"sigma": sigma}},
                "global_search": False,
            }
        )
    )
    return experiment_from_arrays("ramp.csv", rows, cols), spec


def refit_cost(fmu, data, spec, result) -> float:
    """Simulations of plain re-fits from the spec's start with one parameter fixed at a CI end."""
    costs = []
    for name, p in list(result.parameters.items())[:3]:
        end = next((e for e in p.ci_simultaneous if e is not None), None)
        if end is None:
            continue
        others = {k: v for k, v in spec.parameters.items() if k != name}
        fixed_spec = spec.model_copy(update={"parameters": others, "fixed": {name: end}})
        problem = make_problem(fmu, [data], fixed_spec)
        fit = fit_problem(problem, global_search=False)
        costs.append(fit.cost.simulations)
    return float(np.mean(costs)) if costs else float("nan")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--workers", type=int, default=os.cpu_count())
    parser.add_argument("--snr", type=float, nargs="*", default=[1000.0, 25.0])
    parser.add_argument("--rate", type=float, default=5.0, help="sampling rate, Hz")
    parser.add_argument("--seed", type=int, default=1, help="noise seed")
    parser.add_argument("--reference", nargs="*", default=[], help="parameters to check exactly")
    args = parser.parse_args()
    fmu = builtin_fmu("tractor_implement")
    print(
        f"tractor_implement, ramp {args.rate:g} Hz 10 s, noise seed {args.seed}, 6 tire "
        f"parameters, {args.workers} workers"
    )
    print(
        f"{'SNR':>6} {'wall s':>8} {'sims':>7} {'points':>7} {'sims/pt':>8} {'refit sims':>11}"
        f" {'check sims':>11} {'end refits':>11}"
    )
    rows = []
    for snr in args.snr:
        data, spec = dataset(fmu, snr, seed=args.seed, rate=args.rate)
        t0 = time.perf_counter()
        result = fmuid.profile(fmu, [data], spec, workers=args.workers)
        wall = time.perf_counter() - t0
        points = sum(len(p.points) - 1 for p in result.parameters.values())
        profile_sims = result.cost.simulations - result.fit.cost.simulations
        scratch = refit_cost(fmu, data, spec, result)
        checks = result.checks["fit"]["simulations"] + sum(
            p.quality.check_simulations for p in result.parameters.values()
        )
        end_refits = sum(p.quality.end_refits for p in result.parameters.values())
        print(
            f"{snr:6g} {wall:8.2f} {result.cost.simulations:7d} {points:7d} "
            f"{profile_sims / points:8.1f} {scratch:11.1f} {checks:11d} {end_refits:11d}"
        )
        rows.append((snr, result, make_problem(fmu, [data], spec)))
    for snr, result, problem in rows:
        print(f"\nSNR {snr:g}: simultaneous 68% CIs")
        for name, p in result.parameters.items():
            lo, hi = p.ci_simultaneous
            fmt = lambda v: "null" if v is None else f"{v:.5g}"  # noqa: E731
            q = p.quality
            print(
                f"  {name:7s} {p.estimate:12.5g}  [{fmt(lo)}, {fmt(hi)}]  {p.status}"
                f"  checks {q.checks}, jumps {q.jumps}, lower valleys {q.lower_valleys},"
                f" re-walks {q.rewalks}{', UNSETTLED' if q.unsettled else ''}"
            )

        if args.reference:
            print_reference(problem, result, args.reference)


def print_reference(problem, result, names) -> None:
    """Print each end of ``names`` beside the exact reference crossing (error in half-widths)."""
    path = Path(__file__).resolve().parent.parent / "tests" / "profiling" / "reference.py"
    spec = importlib.util.spec_from_file_location("reference", path)
    reference = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(reference)
    z_hat = result.fit.z_estimate()
    print(f"  {'end':24s} {'fmuid':>12} {'reference':>12} {'error':>9}")
    for name in names:
        i = problem.names.index(name)
        ref = reference.ReferenceProfile(problem, i, z_hat)
        p = result.parameters[name]
        for kind, ci in (("pointwise", p.ci_pointwise), ("simultaneous", p.ci_simultaneous)):
            for k, end in enumerate(ci):
                bound = (problem.lower if k == 0 else problem.upper)[i]
                guess = problem.to_z({**result.fit.estimates, name: bound if end is None else end})
                exact = ref.crossing(result.chi2, result.thresholds[kind], float(guess[i]))
                ours = "open" if end is None else f"{end:.5g}"
                there = "open" if exact is None else f"{z_to_value(exact, problem.scales[i]):.5g}"
                if exact is None or end is None:
                    error = "right" if (exact is None) == (end is None) else "WRONG"
                else:
                    error = f"{100 * abs(guess[i] - exact) / abs(exact - z_hat[i]):.3f} %"
                side = "lo" if k == 0 else "hi"
                print(f"  {name + ' ' + kind + ' ' + side:24s} {ours:>12} {there:>12} {error:>9}")


if __name__ == "__main__":
    main()
