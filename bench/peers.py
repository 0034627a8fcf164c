"""fmuid beside pyPESTO 0.7.0 on the same FMU and data: wall time, simulations, CI-end errors.

Bench only: pyPESTO is never a runtime dependency of fmuid. Install it beside the venv, e.g.
``pip install --target /tmp/peers --no-deps pypesto==0.7.0 pandas tqdm h5py`` and run
``PYTHONPATH=service:/tmp/peers python bench/peers.py``.

The case is the tractor's ramp 5 Hz at SNR 25 (noise seed 1): C_atf's upper simultaneous end
lies in a second, lower valley. fmuid runs twice: a full study (all six parameters, with the
check of the fit) and the bench's parameters alone from the checked fit; pyPESTO profiles the
bench's parameters from the same fit. Every pointwise and simultaneous CI end is compared with
an exact reference crossing computed here by root-finding on multi-start scipy re-fits
(``tests/profiles/reference.py``). pyPESTO runs twice: with its defaults (L-BFGS-B,
finite-difference gradients, ``ProfileOptions()``) and tuned (trust-region least squares on the
residuals, the simultaneous threshold as its stop ratio, shorter steps). Simulations count FMU
runs (pyPESTO's through a module-level counter in its objective functions, which survives the
copies pyPESTO makes; fmuid's own count less the initial fit); wall times are on one core
unless ``--workers`` says otherwise.
"""

from __future__ import annotations

import argparse
import importlib.util
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from fmuid.estimation.optimize import fit_problem
from fmuid.estimation.problem import Problem
from fmuid.model.builtin import builtin_fmu
from fmuid.profiling.engine import profile_problem, thresholds
from fmuid.profiling.result import ProfileResult
from fmuid.stages import make_problem

HERE = Path(__file__).resolve().parent


def _load(name: str, path: Path):  # noqa: ANN202 - a module loaded from a file
    spec = importlib.util.spec_from_file_location(name, path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


#: pyPESTO's tuned steps (log10 units). Shorter steps, or the relative step family turned off,
#: did not make its ends right here (its re-fits stay in a higher valley below C_atf's and
#: C_atr's estimates) and cost more simulations.
TUNED_STEPS = {
    "default_step_size_absolute": 0.005,
    "min_step_size_absolute": 0.001,
    "max_step_size_absolute": 0.05,
}

#: FMU simulations made by pyPESTO's objective. Module-level, so that the copies pyPESTO makes
#: of its problem and objective all add to the same count (pyPESTO runs in this process).
SIMULATIONS = 0


def counted(problem: Problem) -> tuple[Callable, Callable]:
    """Return pyPESTO's objective functions: half chi2 and the residuals, each run counted."""

    def residuals(z: np.ndarray) -> np.ndarray:
        global SIMULATIONS
        SIMULATIONS += len(problem.experiments)
        return problem.residuals(z)

    def half_chi2(z: np.ndarray) -> float:
        r = residuals(z)
        return 0.5 * float(r @ r)

    return half_chi2, residuals


def run_pypesto(
    problem: Problem, z_hat: np.ndarray, index: list[int], tuned: bool, thr: dict[str, float]
) -> tuple[int, dict[str, dict[str, tuple[float | None, float | None]]]]:
    """Profile ``index`` with pyPESTO from the optimum ``z_hat``.

    Returns the simulations it made and, per parameter and threshold kind, the ends in z.
    """
    import pypesto
    import pypesto.optimize
    import pypesto.profile
    from pypesto.engine import SingleCoreEngine
    from pypesto.objective import FD

    global SIMULATIONS
    SIMULATIONS = 0
    names = list(problem.names)
    half_chi2, residuals = counted(problem)
    if tuned:
        objective = FD(pypesto.Objective(fun=half_chi2, res=residuals), grad=True, sres=True)
        optimizer = pypesto.optimize.ScipyOptimizer(method="ls_trf")
        options = pypesto.profile.ProfileOptions(
            ratio_min=0.5 * np.exp(-thr["simultaneous"] / 2.0), **TUNED_STEPS
        )
    else:
        objective = FD(pypesto.Objective(fun=half_chi2), grad=True)
        optimizer = pypesto.optimize.ScipyOptimizer()
        options = pypesto.profile.ProfileOptions()
    pproblem = pypesto.Problem(
        objective, problem.z_lower, problem.z_upper, x_names=names, x_guesses=z_hat[None, :]
    )
    result = pypesto.optimize.minimize(pproblem, optimizer, n_starts=1, progress_bar=False)
    result = pypesto.profile.parameter_profile(
        pproblem, result, optimizer, engine=SingleCoreEngine(), profile_index=index,
        profile_options=options, progress_bar=False,
    )  # fmt: skip
    ends: dict[str, dict[str, tuple[float | None, float | None]]] = {}
    for i in index:
        prof = result.profile_result.get_profiler_result(i_par=i)
        xs, ratios = prof.x_path[i], prof.ratio_path
        ends[names[i]] = {}
        for kind, t in thr.items():
            level = np.exp(-t / 2.0)
            lo, hi = pypesto.profile.calculate_approximate_ci(xs, ratios, level)
            lo_open = lo <= problem.z_lower[i] + 1e-12 and ratios[np.argmin(xs)] > level
            hi_open = hi >= problem.z_upper[i] - 1e-12 and ratios[np.argmax(xs)] > level
            ends[names[i]][kind] = (None if lo_open else float(lo), None if hi_open else float(hi))
    return SIMULATIONS, ends


def fmuid_ends(
    prof: ProfileResult, names: list[str]
) -> dict[str, dict[str, tuple[float | None, float | None]]]:
    """The CI ends of ``names`` in fitted coordinates (log10 for these parameters)."""
    out = {}
    for n in names:
        p = prof.parameters[n]
        out[n] = {
            kind: tuple(None if v is None else float(np.log10(v)) for v in ci)
            for kind, ci in (("pointwise", p.ci_pointwise), ("simultaneous", p.ci_simultaneous))
        }
    return out  # type: ignore[return-value]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--parameters", nargs="*", default=["C_atf", "C_atr"])
    parser.add_argument("--workers", type=int, default=1, help="fmuid's worker processes")
    args = parser.parse_args()
    bench = _load("bench_profile", HERE / "profile.py")
    reference = _load("reference", HERE.parent / "tests" / "profiles" / "reference.py")
    fmu = builtin_fmu("tractor_implement")
    data, spec = bench.dataset(fmu, 25.0, seed=1)
    problem = make_problem(fmu, [data], spec)
    fit = fit_problem(problem, global_search=False)
    thr = thresholds(spec.confidence, problem.n_free)
    index = [problem.names.index(n) for n in args.parameters]
    rows = {}
    t0 = time.perf_counter()
    prof = profile_problem(problem, fit, workers=args.workers)
    sims = prof.cost.simulations - fit.cost.simulations
    rows["fmuid, all 6 (fit check too)"] = (time.perf_counter() - t0, sims, prof)
    t0 = time.perf_counter()
    only = profile_problem(problem, prof.fit, only=args.parameters, workers=args.workers)
    sims = only.cost.simulations - prof.fit.cost.simulations
    rows[f"fmuid, {len(index)} from the checked fit"] = (time.perf_counter() - t0, sims, only)
    z_hat, chi2_hat = prof.fit.z_estimate(), prof.fit.chi2
    table = {
        label: (wall, sims, fmuid_ends(p, args.parameters))
        for label, (wall, sims, p) in rows.items()
    }
    for tuned in (False, True):
        t0 = time.perf_counter()
        sims, ends = run_pypesto(problem, z_hat, index, tuned, thr)
        label = "pyPESTO 0.7.0 " + ("tuned" if tuned else "defaults")
        table[label] = (time.perf_counter() - t0, sims, ends)
    exact: dict[str, dict[str, tuple[float | None, ...]]] = {}
    for name, i in zip(args.parameters, index, strict=True):
        ref = reference.ReferenceProfile(problem, i, z_hat)
        exact[name] = {
            kind: tuple(
                ref.crossing(chi2_hat, t, float(bound))
                for bound in (problem.z_lower[i], problem.z_upper[i])
            )
            for kind, t in thr.items()
        }
    print(
        "tractor ramp 5 Hz, SNR 25, seed 1; 68 % CI ends (pw: pointwise, sim: simultaneous), "
        "error in % of the half-width against the bench's reference crossings"
    )
    heads = [
        f"{n} {k[:3].replace('poi', 'pw')} {s}"
        for n in args.parameters
        for k in thr
        for s in ("lo", "hi")
    ]
    print(f"{'tool':32s} {'wall s':>7} {'sims':>7}  " + " ".join(f"{h:>13s}" for h in heads))
    for label, (wall, sims, ends) in table.items():
        cells = [
            _error(ends[name][kind][k], exact[name][kind][k], float(z_hat[i]))
            for name, i in zip(args.parameters, index, strict=True)
            for kind in thr
            for k in range(2)
        ]
        print(f"{label:32s} {wall:7.1f} {sims:7d}  " + " ".join(f"{c:>13s}" for c in cells))


def _error(ours: float | None, exact: float | None, z_hat: float) -> str:
    if exact is None:
        return "open: right" if ours is None else "closed: WRONG"
    if ours is None:
        return "open: WRONG"
    return f"{100 * abs(ours - exact) / abs(exact - z_hat):.2f} %"


if __name__ == "__main__":
    main()
