"""fmuid beside pyPESTO 0.7.0 on the same FMU and data: wall time, simulations, CI-end errors.

Bench only: pyPESTO is never a runtime dependency of fmuid. Install it beside the venv, e.g.
``pip install --target /tmp/peers pypesto==0.7.0`` (plus its pure-Python dependencies) and run
``PYTHONPATH=service:/tmp/peers python bench/peers.py``.

The case is the tractor's ramp 5 Hz at SNR 25 (noise seed 1): C_atf's upper simultaneous end
lies in a second, lower valley. Every tool profiles the same parameters from the same fit; each
CI end is compared with an exact reference crossing computed here by root-finding on
multi-start scipy re-fits (``tests/profiles/reference.py``). pyPESTO runs twice: with its
defaults (L-BFGS-B, finite-difference gradients, ``ProfileOptions()``) and tuned (trust-region
least squares on the residuals, the simultaneous threshold as its stop ratio, shorter steps).
"""

from __future__ import annotations

import argparse
import importlib.util
import time
from pathlib import Path

import numpy as np

from fmuid.fit.optimize import fit_problem
from fmuid.fit.problem import Problem
from fmuid.model.builtin import builtin_fmu
from fmuid.profile.engine import profile_problem, thresholds
from fmuid.stages import make_problem

HERE = Path(__file__).resolve().parent


def _load(name: str, path: Path):  # noqa: ANN202 - a module loaded from a file
    spec = importlib.util.spec_from_file_location(name, path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def run_pypesto(problem: Problem, z_hat: np.ndarray, index: list[int], tuned: bool, thr: float):
    """Profile ``index`` with pyPESTO from the optimum ``z_hat``; return the ends in z.

    pyPESTO copies the objective (and with it the problem's simulation counter) for its
    profile tasks, so its simulations are not counted here: compare wall times.
    """
    import pypesto
    import pypesto.optimize
    import pypesto.profile
    from pypesto.objective import FD

    names = list(problem.names)
    if tuned:
        chi2_half = pypesto.Objective(fun=lambda z: 0.5 * problem.chi2(z), res=problem.residuals)
        objective = FD(chi2_half, grad=True, sres=True)
        optimizer = pypesto.optimize.ScipyOptimizer(method="ls_trf")
        options = pypesto.profile.ProfileOptions(
            ratio_min=0.5 * np.exp(-thr / 2.0),
            default_step_size_absolute=0.005,
            min_step_size_absolute=0.001,
            max_step_size_absolute=0.05,
        )
    else:
        objective = FD(pypesto.Objective(fun=lambda z: 0.5 * problem.chi2(z)), grad=True)
        optimizer = pypesto.optimize.ScipyOptimizer()
        options = pypesto.profile.ProfileOptions()
    pproblem = pypesto.Problem(
        objective, problem.z_lower, problem.z_upper, x_names=names, x_guesses=z_hat[None, :]
    )
    result = pypesto.optimize.minimize(pproblem, optimizer, n_starts=1, progress_bar=False)
    result = pypesto.profile.parameter_profile(
        pproblem, result, optimizer, profile_index=index, profile_options=options,
        progress_bar=False,
    )  # fmt: skip
    ends = {}
    for i in index:
        prof = result.profile_result.get_profiler_result(i_par=i)
        xs = prof.x_path[i]
        ratios = prof.ratio_path
        lo, hi = pypesto.profile.calculate_approximate_ci(xs, ratios, np.exp(-thr / 2.0))
        lo_open = lo <= problem.z_lower[i] + 1e-12 and ratios[np.argmin(xs)] > np.exp(-thr / 2)
        hi_open = hi >= problem.z_upper[i] - 1e-12 and ratios[np.argmax(xs)] > np.exp(-thr / 2)
        ends[names[i]] = (None if lo_open else float(lo), None if hi_open else float(hi))
    return ends


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--parameters", nargs="*", default=["C_atf", "C_atr"])
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()
    bench = _load("bench_profile", HERE / "profile.py")
    reference = _load("reference", HERE.parent / "tests" / "profiles" / "reference.py")
    fmu = builtin_fmu("tractor_implement")
    data, spec = bench.dataset(fmu, 25.0, seed=1)
    problem = make_problem(fmu, [data], spec)
    fit = fit_problem(problem, global_search=False)
    thr = thresholds(spec.confidence, problem.n_free)["simultaneous"]
    index = [problem.names.index(n) for n in args.parameters]
    rows: dict[str, tuple[float, int | None, dict]] = {}
    t0 = time.perf_counter()
    prof = profile_problem(problem, fit, only=None, workers=args.workers)
    fmuid_ends = {n: prof.parameters[n].ci_simultaneous for n in args.parameters}
    fmuid_ends = {
        n: tuple(None if v is None else float(np.log10(v)) for v in e)
        for n, e in fmuid_ends.items()
    }
    rows["fmuid (all 6 profiled)"] = (time.perf_counter() - t0, prof.cost.simulations, fmuid_ends)
    z_hat = prof.fit.z_estimate()
    chi2_hat = prof.fit.chi2
    for tuned in (False, True):
        t0 = time.perf_counter()
        ends = run_pypesto(problem, z_hat, index, tuned, thr)
        label = "pyPESTO 0.7.0 " + ("tuned" if tuned else "defaults")
        rows[label] = (time.perf_counter() - t0, None, ends)
    exact = {}
    for name, i in zip(args.parameters, index, strict=True):
        ref = reference.ReferenceProfile(problem, i, z_hat)
        exact[name] = tuple(
            ref.crossing(chi2_hat, thr, float(bound))
            for bound in (problem.z_lower[i], problem.z_upper[i])
        )
    print("tractor ramp 5 Hz, SNR 25, seed 1; simultaneous 68 % ends, error in % of half-width")
    print(f"{'tool':28s} {'wall s':>7} {'sims':>8}  " + "  ".join(
        f"{n + ' ' + s:>14s}" for n in args.parameters for s in ("lo", "hi")
    ))  # fmt: skip
    for label, (wall, sims, ends) in rows.items():
        cells = []
        for name, i in zip(args.parameters, index, strict=True):
            for k in range(2):
                cells.append(_error(ends[name][k], exact[name][k], float(z_hat[i])))
        count = "n/a" if sims is None else str(sims)
        print(f"{label:28s} {wall:7.1f} {count:>8s}  " + "  ".join(f"{c:>14s}" for c in cells))


def _error(ours: float | None, exact: float | None, z_hat: float) -> str:
    if exact is None:
        return "open: right" if ours is None else "closed: WRONG"
    if ours is None:
        return "open: WRONG"
    return f"{100 * abs(ours - exact) / abs(exact - z_hat):.2f} %"


if __name__ == "__main__":
    main()
