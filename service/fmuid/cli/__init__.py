"""The ``fmuid`` console script; its help text is ``_DESCRIPTION``.

Each command imports what it needs when it runs, so that ``fmuid --help`` starts fast;
``fmuid simulate`` lives in :mod:`fmuid.cli.simulate`.
"""

from __future__ import annotations

import argparse
import json
import logging
import math
import os
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from fmuid import __version__
from fmuid.cli.simulate import add_simulate, interface_option
from fmuid.console import (
    EXIT_INTERRUPTED,
    ProgressDisplay,
    exit_on_interrupt,
    fit_table,
    log_handler,
    profile_table,
)
from fmuid.errors import BuildError, DataError, FitError, FmuError, SpecError
from fmuid.model.world import open_registry

log = logging.getLogger("fmuid")

EXIT_OK, EXIT_INTERNAL, EXIT_BAD_INPUT, EXIT_FIT_FAILED, EXIT_BUILD_FAILED = 0, 1, 2, 3, 4
"""Exit status by cause: success, internal failure, bad input (data, spec, an FMU that cannot be
used), no fit because the FMU failed at every trial point or start, a failed build (gcc)."""
EXIT_BY_CAUSE: tuple[tuple[type[Exception], int], ...] = (
    (FitError, EXIT_FIT_FAILED),
    (BuildError, EXIT_BUILD_FAILED),
    (DataError, EXIT_BAD_INPUT),
    (SpecError, EXIT_BAD_INPUT),
    (FmuError, EXIT_BAD_INPUT),
)

_DESCRIPTION = (
    "Which FMU parameters can your measurements pin down, and why do model and data disagree? "
    "Fit, profile likelihoods and diagnosis of FMI 2.0/3.0 FMUs; built-in models: "
    "tractor_implement, msd, msd_parallel, emps."
)


def _write_json(path: Path, payload: dict[str, Any]) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(path.suffix + ".tmp")
    tmp.write_text(json.dumps(payload, indent=2, allow_nan=False) + "\n")
    tmp.replace(path)


def _load_inputs(args: argparse.Namespace) -> tuple[Path, list[Any], Any, Any]:
    """Return the FMU, experiments and spec of a study, and the problem built of them."""
    from fmuid.data import load_experiment, load_spec
    from fmuid.formats.start import start_at
    from fmuid.stages import make_problem

    fmu = _fmu_path(args.fmu)
    experiments = [load_experiment(p) for p in args.data]
    names = [e.name for e in experiments]
    if len(set(names)) != len(names):
        raise DataError(f"two data files share a name ({', '.join(names)}); rename one")
    spec = load_spec(Path(args.spec))
    if args.interface:
        spec = spec.model_copy(update={"interface": args.interface})
    spec = start_at(spec, args.start)
    if args.settle is not None:
        spec = spec.model_copy(update={"settle": args.settle})
    return fmu, experiments, spec, make_problem(fmu, experiments, spec)


def _test_data(args: argparse.Namespace) -> list[Any]:
    """Return the held-out experiments of ``--test-data``."""
    from fmuid.data import load_experiment

    return [load_experiment(p) for p in args.test_data]


def _seconds(text: str) -> float:
    """Parse a non-negative finite number of seconds (``--settle``)."""
    value = float(text)
    if not (value >= 0 and math.isfinite(value)):
        raise argparse.ArgumentTypeError(f"must be a finite number >= 0, not {text}")
    return value


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
    from fmuid.model.native.build import compile_library, library_path

    loop = library_path(out)
    compile_library(loop)
    print(loop)  # noqa: T201
    return EXIT_OK


def _cmd_info(args: argparse.Namespace) -> int:
    from fmuid.console import info_text
    from fmuid.model.info import info

    described = info(args.model, health=not args.no_health)
    text = json.dumps(described.to_dict(), indent=2) if args.json else info_text(described)
    print(text)  # noqa: T201
    return EXIT_OK


def _run_study(
    args: argparse.Namespace, stage: Callable[..., Any], summary: Callable[[Any], str], **kw: Any
) -> int:
    """Run a stage on the command's study: write its JSON (and report), print its summary."""
    fmu, experiments, spec, problem = _load_inputs(args)
    tests = _test_data(args)
    with ProgressDisplay() as progress:
        result = stage(
            fmu, experiments, spec, progress=progress, problem=problem, test_data=tests, **kw
        )
    _write_json(Path(args.out), result.to_dict())
    if args.report:
        _report(result, args, problem)
    print(summary(result))  # noqa: T201
    return EXIT_OK


def _cmd_fit(args: argparse.Namespace) -> int:
    import fmuid

    return _run_study(args, fmuid.fit, fit_table)


def _cmd_profile(args: argparse.Namespace) -> int:
    import fmuid

    return _run_study(args, fmuid.profile, profile_table, workers=args.workers)


def _cmd_diagnose(args: argparse.Namespace) -> int:
    from fmuid.discrepancy import DiagnoseOptions, diagnose

    options = DiagnoseOptions(workers=args.workers or os.cpu_count() or 1)
    return _run_study(args, diagnose, lambda result: result.verdict(), options=options)


def _cmd_design(args: argparse.Namespace) -> int:
    from fmuid.data import load_spec
    from fmuid.experiment_design import design, load_space

    fmu, spec, space = _fmu_path(args.fmu), load_spec(Path(args.spec)), load_space(args.space)
    with ProgressDisplay() as progress:
        result = design(
            fmu,
            spec,
            space,
            workers=args.workers,
            progress=progress,
            checkpoint=Path(args.checkpoint) if args.checkpoint else None,
        )
    _write_json(Path(args.out), result.to_dict())
    if args.report:
        from fmuid.report.design import write_design_report

        print(f"report: {write_design_report(result, Path(args.report))}")  # noqa: T201
    print(f"recommended: {result.best.trial.label}, sensors {', '.join(result.best.trial.outputs)}")  # noqa: T201
    return EXIT_OK


def _report(result: Any, args: argparse.Namespace, problem: Any) -> None:
    """Write the report of ``result`` from the problem the engine computed it on."""
    from fmuid.report import write_report

    path = write_report(result, Path(args.report), problem=problem)
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


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="fmuid", description=_DESCRIPTION)
    parser.add_argument("-v", "--verbose", action="store_true", help="debug logging")
    parser.add_argument("--version", action="version", version=f"fmuid {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("build-fmus", help="compile model_src/ into fmus/")
    p.add_argument("--src", help="model sources (default: the repository's model_src/)")
    p.add_argument("--out", help="output folder (default: the repository's fmus/)")
    p.set_defaults(func=_cmd_build)

    p = sub.add_parser("info", help="a model's parameters, inputs and outputs")
    p.add_argument("model", help="FMU file or built-in model name")
    p.add_argument("--json", action="store_true", help="print JSON instead of tables")
    p.add_argument(
        "--no-health", action="store_true", help="do not run the FMU at its start values"
    )
    p.set_defaults(func=_cmd_info)

    add_simulate(sub)

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
        p.add_argument(
            "--start",
            help="start values: an SSP parameter-value file (.ssv), or a fit or profile result "
            "(.json: its estimates, without the global search)",
        )
        p.add_argument(
            "--test-data",
            action="append",
            default=[],
            help="held-out CSV file (repeatable): the fitted model's simulation error on it",
        )
        p.add_argument(
            "--settle",
            type=_seconds,
            help="settle-in window [s] left out of the likelihood (default: the spec's settle)",
        )
        interface_option(p)
        if name in ("profile", "diagnose"):
            p.add_argument("--workers", type=int, help="worker processes (default: CPU count)")
        p.set_defaults(func=func)

    from fmuid.formats.cli import add_commands

    add_commands(sub)

    p = sub.add_parser("design", help="propose the experiment that identifies the parameters")
    p.add_argument("--fmu", required=True, help="FMU file or built-in model name")
    p.add_argument("--spec", required=True, help="spec JSON: free parameters, bounds, nominal")
    p.add_argument("--space", required=True, help="experiment space JSON (E.json)")
    p.add_argument("--out", required=True, help="result JSON")
    p.add_argument("--report", help="write index.html and plots into this folder")
    p.add_argument("--workers", type=int, default=1, help="profile workers of the verification")
    p.add_argument(
        "--checkpoint",
        help="keep finished evaluations in this folder; a re-run with the same inputs resumes",
    )
    p.set_defaults(func=_cmd_design)

    p = sub.add_parser("serve", help="run the HTTP service")
    p.add_argument("--host", help="listen address (default: FMUID_HOST, else 127.0.0.1)")
    p.add_argument("--port", type=int, help="listen port (default: FMUID_PORT, else 8000)")
    p.set_defaults(func=_cmd_serve)

    p = sub.add_parser("demo", help="the thesis study end to end on the tractor model")
    p.add_argument("--out", default="demo-report", help="report folder")
    p.add_argument("--grid", choices=("full", "small"), default="full")
    p.add_argument("--workers", type=int)
    p.set_defaults(func=_cmd_demo)
    for command in sub.choices.values():  # -v also after the command: fmuid fit ... -v
        command.add_argument(
            "-v", "--verbose", action="store_true", default=argparse.SUPPRESS, help="debug logging"
        )
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the ``fmuid`` command; return its exit status."""
    args = _parser().parse_args(argv)
    tty = sys.stderr.isatty()
    quiet = tty and args.command in ("fit", "profile", "diagnose", "design")
    logging.basicConfig(
        level=logging.DEBUG if args.verbose else logging.WARNING if quiet else logging.INFO,
        handlers=[log_handler(tty)],
    )
    if argv is None and args.command != "serve":
        exit_on_interrupt()  # the console script only: a caller of main() keeps its own handler
    func: Callable[[argparse.Namespace], int] = args.func
    try:
        with open_registry():
            return func(args)
    except (FitError, BuildError, DataError, SpecError, FmuError) as exc:
        sys.stderr.write(f"fmuid {args.command}: error: {exc}\n")
        return next(code for cause, code in EXIT_BY_CAUSE if isinstance(exc, cause))
    except BrokenPipeError:
        sys.stderr.close()  # the reader (e.g. `| head`) is gone: nothing left to say
        return EXIT_OK
    except KeyboardInterrupt:
        sys.stderr.write("interrupted\n")
        return EXIT_INTERRUPTED
    except Exception as exc:  # noqa: BLE001 - last resort: exit 1 with the reason, not a traceback
        log.debug("internal failure", exc_info=True)
        sys.stderr.write(f"fmuid {args.command}: internal error: {type(exc).__name__}: {exc}\n")
        return EXIT_INTERNAL
