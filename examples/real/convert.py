"""Write the Silverbox and EMPS benchmark records as fmuid data files for the built-in FMUs.

The benchmarks' CSV files name their signals ``u``, ``y`` (and EMPS ``q_ref``); fmuid reads one
column per FMU variable, so this script renames them and cuts the official splits:

- Silverbox, for ``msd`` (``f`` <- V1, ``x`` <- V2, both in volts): ``silverbox_train4000.csv``
  (the first 4000 samples of the training multisine), ``silverbox_train.csv`` (the whole training
  range, 65,062 samples), ``silverbox_test_multisine.csv`` and ``silverbox_test_arrow.csv``
  (the official test sets).
- EMPS, for ``emps`` (``q_ref``, ``qm`` <- y, ``vir`` <- u): ``emps_estimation.csv`` and
  ``emps_test.csv``.

Each file's time starts at 0 (the FMUs start at rest at the first sample; the specs' ``settle``
window leaves the start-up out). Usage::

    python examples/real/convert.py OUT_DIR [--real /work/shared/real]
"""

from __future__ import annotations

import argparse
import csv
import logging
from pathlib import Path

import numpy as np

logger = logging.getLogger("convert")

SILVERBOX_SETS = {
    "silverbox_train4000.csv": (40650, 44650),
    "silverbox_train.csv": (40650, 105712),
    "silverbox_test_multisine.csv": (105712, 127400),
    "silverbox_test_arrow.csv": (100, 40575),
}
"""Output file -> official sample range [first, last) of ``silverbox_SNLS80mV.csv``."""
EMPS_SETS = {"emps_estimation.csv": "emps_estimation.csv", "emps_test.csv": "emps_test.csv"}
"""Output file -> the benchmark's file."""


def read_columns(path: Path) -> dict[str, np.ndarray]:
    """Read a CSV file with a header row into one float array per column."""
    with path.open(newline="") as stream:
        reader = csv.reader(stream)
        header = next(reader)
        rows = np.array([[float(cell) for cell in row] for row in reader if row])
    return {name: rows[:, j] for j, name in enumerate(header)}


def write_columns(path: Path, columns: dict[str, np.ndarray]) -> None:
    """Write equally long columns as a CSV file with a header row."""
    table = np.column_stack(list(columns.values()))
    np.savetxt(path, table, delimiter=",", header=",".join(columns), comments="", fmt="%.10g")
    logger.info("wrote %s (%d rows)", path, table.shape[0])


def convert(real: Path, out: Path) -> None:
    """Write every file of the module's docstring from the benchmarks in ``real`` into ``out``."""
    out.mkdir(parents=True, exist_ok=True)
    silverbox = read_columns(real / "silverbox" / "silverbox_SNLS80mV.csv")
    for name, (first, last) in SILVERBOX_SETS.items():
        time = silverbox["time"][first:last]
        columns = {"f": silverbox["u"][first:last], "x": silverbox["y"][first:last]}
        write_columns(out / name, {"time": time - time[0], **columns})
    for name, source in EMPS_SETS.items():
        emps = read_columns(real / "emps" / source)
        columns = {"q_ref": emps["q_ref"], "qm": emps["y"], "vir": emps["u"]}
        write_columns(out / name, {"time": emps["time"] - emps["time"][0], **columns})


def main() -> None:
    """Parse the command line and convert."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("out", type=Path, help="folder to write the data files into")
    parser.add_argument(
        "--real", type=Path, default=Path("/work/shared/real"), help="the benchmarks' folder"
    )
    args = parser.parse_args()
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    convert(args.real, args.out)


if __name__ == "__main__":
    main()
