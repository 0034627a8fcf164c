"""The fmuid vendor annotation: planar paths read from the FMU, none where none is declared."""

from __future__ import annotations

import ast
import collections
import json
import logging
import shutil
import zipfile
from pathlib import Path

import pytest

from fmuid.model.annotations import PlanarPath, planar_paths

ROOT = Path(__file__).resolve().parents[2]
GENERIC = ["estimation", "profiling", "plots", "discrepancy", "report"]
"""Packages that must work for any FMU (``demo/`` is the thesis and may name its model)."""


def test_tractor_declares_its_cg_paths(tractor_fmu: Path) -> None:
    assert planar_paths(tractor_fmu) == (
        PlanarPath("tractor CG", "x_tc", "y_tc"),
        PlanarPath("implement CG", "x_ic", "y_ic"),
    )


def test_an_fmu_without_annotation_has_no_paths(msd_fmu: Path) -> None:
    assert planar_paths(msd_fmu) == ()


def test_a_path_without_y_is_left_out_and_named(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    fmu = tmp_path / "paths.fmu"
    with zipfile.ZipFile(fmu, "w") as archive:
        archive.writestr(
            "modelDescription.xml",
            '<fmiModelDescription><VendorAnnotations><Tool name="fmuid"><Model>'
            '<Path label="ship" x="east" y="north"/><Path label="buoy" x="bx"/>'
            "</Model></Tool></VendorAnnotations></fmiModelDescription>",
        )
    with caplog.at_level(logging.WARNING, logger="fmuid.model.annotations"):
        assert planar_paths(fmu) == (PlanarPath("ship", "east", "north"),)
    assert "needs label, x and y" in caplog.text and "buoy" in caplog.text


def test_a_file_that_is_no_fmu_has_no_paths(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    bad = tmp_path / "bad.fmu"
    bad.write_text("not a zip")
    with caplog.at_level(logging.WARNING, logger="fmuid.model.annotations"):
        assert planar_paths(bad) == ()
    assert "no vendor annotations read" in caplog.text


def test_generic_packages_name_no_variable_of_the_tractor_model() -> None:
    table = json.loads((ROOT / "model_src" / "tractor_implement" / "variables.json").read_text())
    names = {v["name"] for v in table["variables"] if len(v["name"]) > 1}
    found = []
    for package in GENERIC:
        for path in sorted((ROOT / "service" / "fmuid" / package).glob("*.py")):
            for node in ast.walk(ast.parse(path.read_text())):
                if isinstance(node, ast.Constant) and node.value in names:
                    found.append(f"{path.name}:{node.lineno} {node.value!r}")
    assert found == []


def test_a_model_reads_its_file_once_and_keeps_the_annotation(
    tractor_fmu: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """One disk read per parse, no zip opened on the file, one ElementTree parse by fmuid.

    fmpy builds its model description from the same bytes in memory; the annotation is read
    from the model afterwards, with the file gone.
    """
    import builtins
    import io
    import xml.etree.ElementTree as ET

    from fmuid.model.fmu import FmuModel

    fmu = Path(shutil.copy(tractor_fmu, tmp_path / "copy.fmu"))
    counts = collections.Counter()
    real_open, real_zip, real_parse = io.open, zipfile.ZipFile, ET.fromstring

    def counting_open(file, *args, **kwargs):
        counts["disk"] += str(file) == str(fmu)
        return real_open(file, *args, **kwargs)

    class CountingZip(real_zip):
        def __init__(self, file, *args, **kwargs):
            counts["zip on disk"] += not hasattr(file, "read")
            super().__init__(file, *args, **kwargs)

    def counting_parse(text, *args, **kwargs):
        counts["xml"] += 1
        return real_parse(text, *args, **kwargs)

    monkeypatch.setattr(io, "open", counting_open)
    monkeypatch.setattr(builtins, "open", counting_open)
    monkeypatch.setattr(zipfile, "ZipFile", CountingZip)
    monkeypatch.setattr(ET, "fromstring", counting_parse)
    model = FmuModel(fmu)
    assert (counts["disk"], counts["zip on disk"], counts["xml"]) == (1, 0, 1)
    fmu.unlink()
    assert planar_paths(model) == (
        PlanarPath("tractor CG", "x_tc", "y_tc"),
        PlanarPath("implement CG", "x_ic", "y_ic"),
    )
    assert (counts["disk"], counts["zip on disk"], counts["xml"]) == (1, 0, 1)
