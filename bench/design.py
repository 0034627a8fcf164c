"""Experiment design for the tractor's six tire parameters (thesis section 3.2.3.1 revisited).

For each SNR (noise sigma = max|gam_t| of the thesis ramp / SNR on both yaw rates, as thesis
eq. 3.28), ``fmuid design`` screens step, ramp, chirp, multisine and double-lane-change tests of
10 s (the thesis's duration) with steer up to 10 degrees at 5 or 10 Hz, measuring the two yaw
rates; the best designs are verified by profiles on fresh simulated data. The thesis ramp
(5 Hz, 10 s) is profiled on the same number of draws, and the table compares the median 68 %
simultaneous CI widths (decades) and their geometric mean over the six parameters. Screen and
verification are timed separately; one task is one screened trial or one verified design on one
noise draw, on ``--workers`` local processes, and with ``--dask`` again on a dask LocalCluster of
2 separate worker processes (1 thread each), whose numbers must equal the local run's (the ramp
is profiled once, locally).
``--sensors`` also asks which sensor added to the yaw rates helps most, ``--masses`` what freeing
masses and inertias costs (Fisher screen only).

    PYTHONPATH=service python bench/design.py --snr 25 --draws 5 [--workers 2] [--dask]
    PYTHONPATH=service python bench/design.py --snr 25 --draws 2 --candidates 4 --dask
    PYTHONPATH=service python bench/design.py --no-study --sensors --masses
"""

from __future__ import annotations

import argparse
import json
import math
import time

import numpy as np

from fmuid.data import spec_from_json
from fmuid.demo import BOUNDS, NOMINAL
from fmuid.experiment_design import design, space_from_json
from fmuid.experiment_design.signals import Trial
from fmuid.experiment_design.verify import verify
from fmuid.model.builtin import builtin_fmu
from fmuid.model.fmu import FmuModel
from fmuid.model.simulator import Simulator

RAMP = Trial(
    "ramp", {"amplitude": 0.17452, "start": 1.0, "rise": 0.5}, 10.0, 5.0, ("gam_t", "gam_i")
)
MASSES = {"m_t": 9391.0, "m_i": 2127.0, "I_tz": 35709.0, "I_iz": 6402.0}


def ramp_sigma(fmu, snr: float) -> float:
    """Noise sigma of the thesis ramp at ``snr`` (max |gam_t| / SNR)."""
    t = np.round(np.arange(51) * 0.2, 10)
    y = Simulator(fmu).simulate(
        {}, np.array([0, 1, 1.5, 10.0]), {"delta": np.array([0, 0, 0.17452, 0.17452])}, t, ["gam_t"]
    )
    return float(np.max(np.abs(y[:, 0])) / snr)


def make_spec(masses: bool = False):
    params = {
        n: {"start": v, "lower": BOUNDS[n][0], "upper": BOUNDS[n][1]} for n, v in NOMINAL.items()
    }
    if masses:
        params |= {n: {"start": v, "lower": v / 5, "upper": v * 5} for n, v in MASSES.items()}
    doc = {
        "parameters": params,
        "inputs": ["delta"],
        "outputs": {"gam_t": {"sigma": 1.0}},
        "global_search": False,
    }
    return spec_from_json(json.dumps(doc), "bench spec")


def make_space(sigma: float, args: argparse.Namespace, extra_sensors: bool = False):
    amp = [0.05, 0.17453]
    box = NOMINAL.items()
    outputs = {"gam_t": {"sigma": sigma}, "gam_i": {"sigma": sigma}}
    if extra_sensors:
        outputs |= {
            "psi_t": {"sigma": 0.005},
            "psi_i": {"sigma": 0.005},
            "y_tc": {"sigma": 0.02},
            "y_ic": {"sigma": 0.02},
            "v_tc": {"sigma": 0.02},
        }
    doc = {
        "input": "delta",
        "families": {
            "step": {"amplitude": amp, "time": [0.5, 3.0]},
            "ramp": {"amplitude": amp, "start": [0.5, 3.0], "rise": [0.2, 2.0]},
            "chirp": {"f0": [0.05, 0.5], "f1": [0.3, 2.0], "amplitude": amp},
            "multisine": {
                "f_min": [0.05, 0.3],
                "f_max": [0.5, 2.0],
                "amplitude": amp,
                "tones": [2, 8],
            },
            "double_lane_change": {"amplitude": amp, "duration": [1.0, 3.0]},
        },
        "duration": 10.0,
        "rates_hz": [5, 10],
        "outputs": outputs,
        "base_outputs": ["gam_t", "gam_i"],
        "max_sensors": 3 if extra_sensors else 2,
        "longest_test": 10.0,
        "candidates": args.candidates,
        "verify_designs": 0 if extra_sensors else args.verify,
        "draws": args.draws,
        "robust": {"points": args.points, "box": {n: [v / 1.5, v * 1.5] for n, v in box}},
        "seed": 0,
    }
    return space_from_json(json.dumps(doc), "bench space")


def geo(widths: dict[str, float]) -> float:
    w = np.array(list(widths.values()))
    return float(np.exp(np.mean(np.log(w))))


def run_study(fmu, spec, space, args, executor) -> tuple:
    """The design study (on the local pool, or on ``executor``) and its wall time [s]."""
    workers = args.workers if executor is None else None
    t0 = time.perf_counter()
    result = design(fmu, spec, space, workers=workers, executor=executor)
    return result, time.perf_counter() - t0


def study(fmu, snr: float, args: argparse.Namespace, cluster) -> None:
    sigma = ramp_sigma(fmu, snr)
    spec, space = make_spec(), make_space(sigma, args)
    result, total = run_study(fmu, spec, space, args, None)
    t1 = time.perf_counter()
    ramp = verify(FmuModel(fmu), spec, space, RAMP, seed=7, workers=args.workers)
    t_ramp = time.perf_counter() - t1
    best = result.best
    stage = result.stage_seconds
    print(f"\n## SNR {snr:g} (sigma {sigma:.4g} rad/s), {result.screened} designs screened")
    print(
        f"screen {stage['screen_seconds']:.1f} s, verification of {args.verify} design(s) x "
        f"{args.draws} draws {stage['verify_seconds']:.1f} s (total {total:.1f} s); "
        f"ramp profiles {t_ramp:.1f} s ({args.workers} local worker(s))"
    )
    print(f"recommended: {best.trial.label}")
    print(
        "| parameter | ramp 5 Hz width | ramp identifiable | recommended predicted "
        "| recommended width | identifiable | ramp/recommended |\n|---|---|---|---|---|---|---|"
    )
    rec = {n: best.verified.median_width(n) for n in spec.parameters} if best.verified else {}
    rmp = {n: ramp.median_width(n) for n in spec.parameters}
    for n in spec.parameters:
        pred = best.predicted[n].get("width_z", math.nan)
        count = best.verified.identifiable[n] if best.verified else "-"
        r = rec.get(n, math.nan)
        print(
            f"| {n} | {rmp[n]:.4f}{'+' * bool(ramp.open_ended[n])} "
            f"| {ramp.identifiable[n]}/{ramp.draws} | {pred:.4f} "
            f"| {r:.4f} | {count}/{args.draws} | {rmp[n] / r:.2f} |"
        )
    print(f"| geometric mean | {geo(rmp):.4f} | | | {geo(rec):.4f} | | {geo(rmp) / geo(rec):.2f} |")
    if cluster is None:
        return
    from distributed import Client

    with Client(cluster) as client:
        remote, total_d = run_study(fmu, spec, space, args, client)
    same = _numbers(remote) == _numbers(result)
    print(f"\n### Executors (SNR {snr:g}): wall times [s]; same ranking and numbers: {same}")
    print("| executor | screen | verification | total |\n|---|---|---|---|")
    for name, r, t in (
        (f"local pool, {args.workers} process(es)", result, total),
        ("dask LocalCluster, 2 worker processes x 1 thread", remote, total_d),
    ):
        st = r.stage_seconds
        print(f"| {name} | {st['screen_seconds']:.1f} | {st['verify_seconds']:.1f} | {t:.1f} |")


def _numbers(result) -> dict:
    doc = result.to_dict()
    return {**doc, "cost": doc["cost"]["simulations"]}


def sensors(fmu, snr: float, args: argparse.Namespace) -> None:
    sigma = ramp_sigma(fmu, snr)
    t0 = time.perf_counter()
    result = design(fmu, make_spec(), make_space(sigma, args, extra_sensors=True), verify_designs=0)
    print(f"\n## Which third sensor (SNR {snr:g}; Fisher screen, {time.perf_counter() - t0:.1f} s)")
    print(f"best: {result.best.trial.label}, sensors {', '.join(result.best.trial.outputs)}")
    base = result.best.trial.with_(outputs=("gam_t", "gam_i"))
    print("| sensors | predicted geometric-mean width [decades] |\n|---|---|")
    for d in result.designs:
        if d.trial.with_(outputs=base.outputs) == base:
            w = {n: p.get("width_z", math.inf) for n, p in d.predicted.items()}
            print(f"| {', '.join(d.trial.outputs)} | {geo(w):.4f} |")


def masses(fmu, snr: float, args: argparse.Namespace) -> None:
    sigma = ramp_sigma(fmu, snr)
    t0 = time.perf_counter()
    result = design(fmu, make_spec(masses=True), make_space(sigma, args), verify_designs=0)
    took = time.perf_counter() - t0
    print(f"\n## Masses and inertias free as well (SNR {snr:g}; Fisher screen, {took:.1f} s)")
    for c in result.not_identifiable_by_any:
        print(f"not identifiable by any design: {c['meaning']}")
    print(f"best: {result.best.trial.label}")
    for n, p in result.best.predicted.items():
        print(f"  {n}: {p['status']}, predicted width {p.get('width_z', float('nan')):.4f} decades")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--snr", type=float, nargs="+", default=[25.0])
    parser.add_argument("--draws", type=int, default=5)
    parser.add_argument("--verify", type=int, default=1, help="designs verified by profiles")
    parser.add_argument("--candidates", type=int, default=12, help="designs per family and rate")
    parser.add_argument("--points", type=int, default=4, help="prior-box points of the screen")
    parser.add_argument("--workers", type=int, default=2, help="local worker processes")
    parser.add_argument(
        "--dask",
        action="store_true",
        help="run the study again on a local dask cluster of 2 worker processes and compare",
    )
    parser.add_argument("--no-study", action="store_true", help="skip the verified SNR study")
    parser.add_argument("--sensors", action="store_true")
    parser.add_argument("--masses", action="store_true")
    args = parser.parse_args()
    fmu = builtin_fmu("tractor_implement")
    cluster = None
    if args.dask:
        from distributed import LocalCluster

        cluster = LocalCluster(
            n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
        )
    try:
        for snr in [] if args.no_study else args.snr:
            study(fmu, snr, args, cluster)
        if args.sensors:
            sensors(fmu, args.snr[0], args)
        if args.masses:
            masses(fmu, args.snr[0], args)
    finally:
        if cluster is not None:
            cluster.close()


if __name__ == "__main__":
    main()
