"""The ``fmuid`` command line (contract: "Command line")."""

from __future__ import annotations

import argparse
import json
import logging
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from fmuid.errors import DataError, FmuError, SpecError
from fmuid.progress import Progress

log = logging.getLogger("fmuid")

EXIT_OK, EXIT_INTERNAL, EXIT_BAD_INPUT = 0, 1, 2


class _ProgressPrinter:
    """Progress on stderr: one rewritten line on a terminal, throttled log lines otherwise."""

    def __init__(self) -> None:
        self.tty = sys.stderr.isatty()
        self.last = 0.0

    def __call__(self, event: Progress) -> None:
        now = time.monotonic()
        final = event.done >= event.total
        if not final and now - self.last < (0.1 if self.tty else 2.0):
            return
        self.last = now
        text = f"{event.stage}: {event.done}/{event.total} {event.detail}"
        if self.tty:
            sys.stderr.write("\r\033[K" + text + ("\n" if final else ""))
            sys.stderr.flush()
        else:
            log.info("%s", text)


def _write_json(path: Path, payload: dict[str, Any]) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(path.suffix + ".tmp")
    tmp.write_text(json.dumps(payload, indent=2, allow_nan=False) + "\n")
    tmp.replace(path)


def _load_inputs(args: argparse.Namespace) -> tuple[Path, list[Any], Any]:
    from fmuid.data import load_experiment, load_spec

    fmu = _fmu_path(args.fmu)
    experiments = [load_experiment(Path(p)) for p in args.data]
    names = [e.name for e in experiments]
    if len(set(names)) != len(names):
        raise DataError(f"two data files share a name ({', '.join(names)}); rename one")
    return fmu, experiments, load_spec(Path(args.spec))


def _fmu_path(text: str) -> Path:
    from fmuid.model.builtin import resolve_fmu

    return resolve_fmu(text)


def _cmd_build(args: argparse.Namespace) -> int:
    from fmuid.model.build import build_fmus
    from fmuid.model.builtin import fmu_dir, model_src_dir

    src = Path(args.src) if args.src else model_src_dir()
    out = Path(args.out) if args.out else fmu_dir()
    for path in build_fmus(src, out):
        print(path)  # noqa: T201
    return EXIT_OK


def _cmd_simulate(args: argparse.Namespace) -> int:
    import numpy as np

    from fmuid.data import load_experiment, load_spec
    from fmuid.fit.predictor import merged_inputs
    from fmuid.model.fmu import USABLE, FmuModel
    from fmuid.model.simulator import Simulator

    fmu = _fmu_path(args.fmu)
    model = FmuModel(fmu)
    experiment = load_experiment(Path(args.data))
    params: dict[str, float | str] = {}
    if args.spec:
        spec = load_spec(Path(args.spec))
        params.update(spec.fixed)
        params.update({n: p.start for n, p in spec.parameters.items()})
        unknown = sorted(set(params) - set(model.parameters))
        if unknown:
            raise SpecError(f"{args.spec}: the FMU has no parameter(s) {', '.join(unknown)}")
        problems = model.usage_problems(spec.parameters, spec.fixed, (), ())
        if problems:
            raise SpecError("\n".join(f"{args.spec}: {problem}" for problem in problems))
    unknown_cols = [
        c
        for c in experiment.columns
        if c not in model.inputs
        and c not in model.outputs
        and not (c.startswith("sigma_") and c[6:] in model.outputs)
    ]
    if unknown_cols:
        raise DataError(
            f"{experiment.name}: column(s) {', '.join(unknown_cols)} are not FMU variables"
        )
    inputs = [c for c in experiment.columns if c in model.inputs]
    held = [c for c in inputs if not model.inputs[c].is_continuous]
    input_time, input_values = merged_inputs(experiment, inputs, held)
    outputs = [n for n, v in model.outputs.items() if v.kind in USABLE["output"]]
    if not outputs:
        types = ", ".join(f"{n} ({v.type_label})" for n, v in model.outputs.items()) or "none"
        raise FmuError(f"{fmu}: no output fmuid can read (its outputs: {types})")
    y = Simulator(fmu).simulate(params, input_time, input_values, experiment.time, outputs)
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    table = np.column_stack([experiment.time, y])
    np.savetxt(
        out, table, delimiter=",", header=",".join(["time", *outputs]), comments="", fmt="%.12g"
    )
    print(out)  # noqa: T201
    return EXIT_OK


def _cmd_fit(args: argparse.Namespace) -> int:
    import fmuid

    fmu, experiments, spec = _load_inputs(args)
    result = fmuid.fit(fmu, experiments, spec, progress=_ProgressPrinter())
    _write_json(Path(args.out), result.to_dict())
    if args.report:
        _report(result, args, fmu, experiments, spec)
    print(f"chi2 {result.chi2:.6g} with {result.n_data} data points; wrote {args.out}")  # noqa: T201
    return EXIT_OK


def _cmd_profile(args: argparse.Namespace) -> int:
    import fmuid

    fmu, experiments, spec = _load_inputs(args)
    result = fmuid.profile(
        fmu, experiments, spec, workers=args.workers, progress=_ProgressPrinter()
    )
    _write_json(Path(args.out), result.to_dict())
    if args.report:
        _report(result, args, fmu, experiments, spec)
    for name, p in result.parameters.items():
        lo, hi = p.ci_simultaneous
        print(f"{name:>12s} {p.estimate:12.6g}  [{_fmt(lo)}, {_fmt(hi)}]  {p.status}")  # noqa: T201
    return EXIT_OK


def _cmd_diagnose(args: argparse.Namespace) -> int:
    from fmuid.diagnose import diagnose

    fmu, experiments, spec = _load_inputs(args)
    result = diagnose(fmu, experiments, spec, progress=_ProgressPrinter())
    _write_json(Path(args.out), result.to_dict())
    if args.report:
        _report(result, args, fmu, experiments, spec)
    print(result.to_dict()["verdict"])  # noqa: T201
    return EXIT_OK


def _report(
    result: Any, args: argparse.Namespace, fmu: Path, experiments: list[Any], spec: Any
) -> None:
    from fmuid.report import write_report

    path = write_report(result, Path(args.report), fmu=fmu, experiments=experiments, spec=spec)
    print(f"report: {path}")  # noqa: T201


def _cmd_serve(args: argparse.Namespace) -> int:
    from fmuid.api import serve

    serve(args.host, args.port)
    return EXIT_OK


def _cmd_demo(args: argparse.Namespace) -> int:
    from fmuid.demo import run_demo

    path = run_demo(Path(args.out), grid=args.grid, workers=args.workers)
    print(f"report: {path}")  # noqa: T201
    return EXIT_OK


def _fmt(v: float | None) -> str:
    return "null" if v is None else f"{v:.6g}"


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="fmuid", description=__doc__)
    parser.add_argument("-v", "--verbose", action="store_true", help="debug logging")
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("build-fmus", help="compile model_src/ into fmus/")
    p.add_argument("--src", help="model sources (default: the repository's model_src/)")
    p.add_argument("--out", help="output folder (default: the repository's fmus/)")
    p.set_defaults(func=_cmd_build)

    p = sub.add_parser("simulate", help="every FMU output at the data's times")
    p.add_argument("--fmu", required=True, help="FMU file or built-in model name")
    p.add_argument("--data", required=True, help="CSV with time and input columns")
    p.add_argument("--spec", help="spec JSON: parameter values (start and fixed)")
    p.add_argument("--out", required=True, help="output CSV")
    p.set_defaults(func=_cmd_simulate)

    for name, func, text in (
        ("fit", _cmd_fit, "fit the free parameters"),
        ("profile", _cmd_profile, "profile likelihood of every free parameter"),
        ("diagnose", _cmd_diagnose, "locate and explain model-data mismatch"),
    ):
        p = sub.add_parser(name, help=text)
        p.add_argument("--fmu", required=True, help="FMU file or built-in model name")
        p.add_argument("--data", required=True, action="append", help="CSV file (repeatable)")
        p.add_argument("--spec", required=True, help="spec JSON")
        p.add_argument("--out", required=True, help="result JSON")
        p.add_argument("--report", help="write index.html and plots into this folder")
        if name == "profile":
            p.add_argument("--workers", type=int, help="worker processes (default: CPU count)")
        p.set_defaults(func=func)

    p = sub.add_parser("serve", help="run the HTTP service")
    p.add_argument("--host", help="listen address (default: FMUID_HOST, else 127.0.0.1)")
    p.add_argument("--port", type=int, help="listen port (default: FMUID_PORT, else 8000)")
    p.set_defaults(func=_cmd_serve)

    p = sub.add_parser("demo", help="the thesis study end to end on the tractor model")
    p.add_argument("--out", default="demo-report", help="report folder")
    p.add_argument("--grid", choices=("full", "small"), default="full")
    p.add_argument("--workers", type=int)
    p.set_defaults(func=_cmd_demo)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the ``fmuid`` command; return its exit status."""
    args = _parser().parse_args(argv)
    logging.basicConfig(
        level=logging.DEBUG if args.verbose else logging.INFO,
        format="%(asctime)s %(levelname)s %(name)s: %(message)s",
        stream=sys.stderr,
    )
    func: Callable[[argparse.Namespace], int] = args.func
    try:
        return func(args)
    except (DataError, SpecError, FmuError) as exc:
        sys.stderr.write(f"fmuid {args.command}: error: {exc}\n")
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        sys.stderr.write("interrupted\n")
        return EXIT_INTERNAL
    except Exception as exc:  # noqa: BLE001 - last resort: exit 1 with the reason, not a traceback
        log.debug("internal failure", exc_info=True)
        sys.stderr.write(f"fmuid {args.command}: internal error: {type(exc).__name__}: {exc}\n")
        return EXIT_INTERNAL


if __name__ == "__main__":
    sys.exit(main())
