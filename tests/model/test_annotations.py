"""The fmuid vendor annotation: planar paths read from the FMU, none where none is declared."""

from __future__ import annotations

import ast
import json
import logging
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
