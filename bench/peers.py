"""fmuid beside pyPESTO 0.7.0 on the same FMU and data: wall time, simulations, CI-end errors.

Bench only: pyPESTO is never a runtime dependency of fmuid. Install it beside the venv, e.g.
``pip install --target /tmp/peers --no-deps pypesto==0.7.0 pandas tqdm h5py`` and run
``PYTHONPATH=service:/tmp/peers python bench/peers.py``.

The cases (``--cases``, noise seed 1) are the tractor's well-posed rate-limited step (``ramp``
5 Hz, SNR 1000), its chirp (5 Hz, SNR 100) and its low-SNR step (ramp 5 Hz, SNR 25, where
C_atf's upper simultaneous end lies in a second, lower valley). fmuid runs twice: a full study
(all six parameters, with the check of the fit) and the bench's parameters alone from the
checked fit (``--parameters``: C_atf and C_atr, or ``all`` six); pyPESTO profiles the
bench's parameters from the same fit, and the ratios of the last table are fmuid's second run
over tuned pyPESTO's. Every pointwise and simultaneous CI end
is compared with an exact reference crossing computed here by root-finding on multi-start scipy
re-fits (``tests/profiling/reference.py``). pyPESTO runs tuned (trust-region least squares on the
residuals, the simultaneous threshold as its stop ratio, shorter steps) and, with
``--defaults``, with its defaults (L-BFGS-B, finite-difference gradients, ``ProfileOptions()``).
Simulations count FMU runs (pyPESTO's through a module-level counter in its objective
functions, which survives the copies pyPESTO makes; fmuid's own count less the initial fit);
wall times are on one core unless ``--workers`` says otherwise.
"""

from __future__ import annotations

import argparse
import importlib.util
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from fmuid.demo.thesis import DESIGNS, simulate_dataset, study_spec
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
        pproblem,
        result,
        optimizer,
        engine=SingleCoreEngine(),
        profile_index=index,
        profile_options=options,
        progress_bar=False,
    )
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


#: The cases: label -> (design, SNR). The ramps use ``bench/profile.py``'s dataset.
CASES = {
    "step 5 Hz SNR 1000": ("ramp", 1000.0),
    "chirp 5 Hz SNR 100": ("chirp", 100.0),
    "step 5 Hz SNR 25": ("ramp", 25.0),
}


def case_data(bench, fmu: Path, kind: str, snr: float, seed: int):  # noqa: ANN001, ANN201
    """The dataset and spec of one case (noise from ``seed``)."""
    if kind == "ramp":
        return bench.dataset(fmu, snr, seed=seed)
    design = next(d for d in DESIGNS if d.kind == kind)
    data, sigma = simulate_dataset(fmu, design, snr, np.random.default_rng(seed))
    return data, study_spec(sigma)


def run_case(bench, reference, fmu: Path, label: str, args: argparse.Namespace) -> dict:  # noqa: ANN001
    """Run fmuid and pyPESTO on one case, print its table and return its summary row."""
    data, spec = case_data(bench, fmu, *CASES[label], seed=args.seed)
    problem = make_problem(fmu, [data], spec)
    fit = fit_problem(problem, global_search=False)
    thr = thresholds(spec.confidence, problem.n_free)
    names = chosen(args.parameters, problem.names)
    index = [problem.names.index(n) for n in names]
    rows = {}
    t0 = time.perf_counter()
    prof = profile_problem(problem, fit, workers=args.workers)
    sims = prof.cost.simulations - fit.cost.simulations
    rows["fmuid, all 6 (fit check too)"] = (time.perf_counter() - t0, sims, prof)
    t0 = time.perf_counter()
    only = profile_problem(problem, prof.fit, only=names, workers=args.workers)
    sims = only.cost.simulations - prof.fit.cost.simulations
    ours = f"fmuid, {len(index)} from the checked fit"
    rows[ours] = (time.perf_counter() - t0, sims, only)
    z_hat, chi2_hat = prof.fit.z_estimate(), prof.fit.chi2
    table = {label: (wall, sims, fmuid_ends(p, names)) for label, (wall, sims, p) in rows.items()}
    for tuned in (False, True) if args.defaults else (True,):
        t0 = time.perf_counter()
        sims, ends = run_pypesto(problem, z_hat, index, tuned, thr)
        name = "pyPESTO 0.7.0 " + ("tuned" if tuned else "defaults")
        table[name] = (time.perf_counter() - t0, sims, ends)
    exact: dict[str, dict[str, tuple[float | None, ...]]] = {}
    for name, i in zip(names, index, strict=True):
        ref = reference.ReferenceProfile(problem, i, z_hat)
        exact[name] = {
            kind: tuple(
                ref.crossing(chi2_hat, t, float(bound))
                for bound in (problem.z_lower[i], problem.z_upper[i])
            )
            for kind, t in thr.items()
        }
    print(
        f"\ntractor {label}, seed {args.seed}; 68 % CI ends (pw: pointwise, sim: simultaneous), "
        "error in % of the half-width against the bench's reference crossings"
    )
    heads = [
        f"{n} {k[:3].replace('poi', 'pw')} {s}" for n in names for k in thr for s in ("lo", "hi")
    ]
    print(f"{'tool':32s} {'wall s':>7} {'sims':>7}  " + " ".join(f"{h:>13s}" for h in heads))
    worst = {}
    for name, (wall, sims, ends) in table.items():
        errors = [
            _error(ends[n][kind][k], exact[n][kind][k], float(z_hat[i]))
            for n, i in zip(names, index, strict=True)
            for kind in thr
            for k in range(2)
        ]
        worst[name] = max(errors, key=lambda e: e[0])[0]
        cells = [text for _, text in errors]
        print(f"{name:32s} {wall:7.1f} {sims:7d}  " + " ".join(f"{c:>13s}" for c in cells))
    peer = "pyPESTO 0.7.0 tuned"
    return {
        "case": label,
        "parameters": len(names),
        "ours": table[ours][:2],
        "peer": table[peer][:2],
        "worst": (worst[ours], worst[peer]),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--cases", nargs="+", choices=list(CASES), default=list(CASES))
    parser.add_argument(
        "--parameters",
        nargs="*",
        default=["C_atf", "C_atr"],
        help="the parameters both tools profile (names of the tractor's, or all)",
    )
    parser.add_argument("--workers", type=int, default=1, help="fmuid's worker processes")
    parser.add_argument("--seed", type=int, default=1, help="noise seed")
    parser.add_argument("--defaults", action="store_true", help="also pyPESTO's defaults")
    args = parser.parse_args()
    bench = _load("bench_profile", HERE / "profile.py")
    reference = _load("reference", HERE.parent / "tests" / "profiling" / "reference.py")
    fmu = builtin_fmu("tractor_implement")
    summary = [run_case(bench, reference, fmu, label, args) for label in args.cases]
    count = summary[0]["parameters"]
    print(
        f"\nfmuid ({count} parameters from the checked fit) / pyPESTO 0.7.0 tuned; "
        "worst end: error as a fraction of the half-width (target: ratios 0.25 / 0.3, ends 0.05)"
    )
    print(
        f"{'case':22s} {'fmuid sims':>10} {'wall s':>7} {'peer sims':>10} {'wall s':>7}"
        f" {'sims ratio':>10} {'wall ratio':>10} {'worst fmuid':>11} {'worst peer':>10}"
    )
    for row in summary:
        (w0, s0), (w1, s1) = row["ours"], row["peer"]
        print(
            f"{row['case']:22s} {s0:10d} {w0:7.1f} {s1:10d} {w1:7.1f} {s0 / s1:10.2f}"
            f" {w0 / w1:10.2f} {row['worst'][0]:11.4f} {row['worst'][1]:10.4f}"
        )


def chosen(parameters: list[str], names: tuple[str, ...]) -> list[str]:
    """The ``--parameters`` asked for: ``all`` for every free parameter; unknown names fail."""
    if parameters == ["all"]:
        return list(names)
    unknown = [p for p in parameters if p not in names]
    if unknown or not parameters:
        raise SystemExit(
            f"--parameters: {', '.join(unknown) or 'none given'}; the tractor's are "
            f"{', '.join(names)} (or all)"
        )
    return parameters


def _error(ours: float | None, exact: float | None, z_hat: float) -> tuple[float, str]:
    """The error of one end as a fraction of the half-width (inf when open or closed wrongly)."""
    if exact is None:
        return (0.0, "open: right") if ours is None else (np.inf, "closed: WRONG")
    if ours is None:
        return np.inf, "open: WRONG"
    error = abs(ours - exact) / abs(exact - z_hat)
    return error, f"{100 * error:.2f} %"


if __name__ == "__main__":
    main()
