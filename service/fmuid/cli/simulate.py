"""``fmuid simulate``: every FMU output at the data's times, at the values a spec gives.

Also the ``--interface`` option, which the study commands share.
"""

from __future__ import annotations

import argparse
import json
import logging
from pathlib import Path
from typing import Any

from fmuid.errors import SpecError

log = logging.getLogger(__name__)


def interface_option(p: argparse.ArgumentParser) -> None:
    """Add ``--interface`` (which FMI interface of an FMU that has both) to a command."""
    p.add_argument(
        "--interface",
        choices=("auto", "co_simulation", "model_exchange"),
        help="FMI interface of an FMU that has both (default: the spec's, else auto = "
        "co-simulation)",
    )


def add_simulate(sub: Any) -> None:
    """Add ``simulate`` to the ``fmuid`` parser's sub-commands."""
    p = sub.add_parser("simulate", help="every FMU output at the data's times")
    p.add_argument("--fmu", required=True, help="FMU file or built-in model name")
    p.add_argument("--data", required=True, help="CSV with time and input columns")
    p.add_argument("--spec", help="spec JSON: parameter values (start, fixed; fixed alone will do)")
    p.add_argument("--out", required=True, help="output CSV")
    interface_option(p)
    p.add_argument(
        "--with-inputs", action="store_true", help="write the input columns beside the outputs"
    )
    p.set_defaults(func=simulate_command)


def simulate_command(args: argparse.Namespace) -> int:
    """Run ``fmuid simulate``: write the outputs (and inputs) as CSV; return exit status 0."""
    import numpy as np

    import fmuid
    from fmuid.data import load_experiment
    from fmuid.model.builtin import resolve_fmu

    experiment = load_experiment(args.data)
    params = simulation_values(Path(args.spec)) if args.spec else {}
    interface = args.interface or (_spec_interface(Path(args.spec)) if args.spec else "auto")
    run = fmuid.simulate(
        resolve_fmu(args.fmu), experiment, params, interface=interface, source=str(args.spec)
    )
    log.info("%s; %s", run.model.kind_label, run.input_handling)
    columns = {"time": run.time, **(run.inputs if args.with_inputs else {}), **run.outputs}
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    np.savetxt(
        out,
        np.column_stack(list(columns.values())),
        delimiter=",",
        header=",".join(columns),
        comments="",
        fmt="%.12g",
    )
    print(out)  # noqa: T201
    return 0


def simulation_values(path: Path) -> dict[str, float | str]:
    """Parameter values of a spec for ``simulate``: ``fixed`` and each parameter's ``start``.

    A spec that only fixes values (no ``parameters`` or ``outputs``) is accepted here.
    """
    from fmuid.data import load_spec

    try:
        raw = json.loads(path.read_text())
    except (OSError, ValueError) as exc:
        raise SpecError(f"{path}: cannot read the spec ({exc})") from exc
    if isinstance(raw, dict) and "parameters" in raw and "outputs" in raw:
        spec = load_spec(path)
        return {**spec.fixed, **{n: p.start for n, p in spec.parameters.items()}}
    if not isinstance(raw, dict) or not isinstance(raw.get("fixed", {}), dict):
        raise SpecError(f"{path}: expected an object with 'fixed' (and optional 'parameters')")
    values: dict[str, float | str] = {}
    for name, value in raw.get("fixed", {}).items():
        if not isinstance(value, int | float | str):
            raise SpecError(f"{path}: fixed.{name}: a number, true/false or text, not {value!r}")
        values[name] = value
    for name, p in raw.get("parameters", {}).items():
        if not isinstance(p, dict) or not isinstance(p.get("start"), int | float):
            raise SpecError(f"{path}: parameters.{name}.start: a number is required")
        values[name] = float(p["start"])
    return values


def _spec_interface(path: Path) -> str:
    """Return the ``interface`` of the spec at ``path`` (default ``auto``), checked."""
    interface = json.loads(path.read_text()).get("interface", "auto")
    if interface not in ("auto", "co_simulation", "model_exchange"):
        raise SpecError(
            f"{path}: interface: {interface!r} is not one of 'auto', 'co_simulation' or "
            "'model_exchange'"
        )
    return str(interface)
