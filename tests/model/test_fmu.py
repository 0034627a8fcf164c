"""Built FMUs: fmpy validation, variable tables vs header and XML, FmuModel checks, build errors."""

from __future__ import annotations

import json
import re
import shutil
import zipfile
from pathlib import Path

import pytest
from fmpy.validation import validate_fmu

from fmuid.errors import BuildError, FmuError
from fmuid.model.build import build_fmus
from fmuid.model.builtin import BUILTIN_MODELS, builtin_fmu, model_src_dir
from fmuid.model.fmu import FmuModel

CONTRACT_START = {
    "tractor_implement": {
        "C_atf": 220000,
        "C_atr": 486000,
        "C_air": 167000,
        "sig_tf": 0.5,
        "sig_tr": 1.0,
        "sig_ir": 0.5,
        "m_t": 9391,
        "m_i": 2127,
        "I_tz": 35709,
        "I_iz": 6402,
        "u_tc": 4.5,
        "a": 1.7,
        "b": 1.2,
        "c": 2.1,
        "d": 3.62,
        "e": 0.1,
        "alpha_sat": 0.0,
        "slope": 0.0,
    },
    "msd": {"m": 1.1, "k": 4.4, "b": 1.6},
    "msd_parallel": {"m": 1.1, "k1": 3.0, "k2": 1.4, "b": 1.6},
    "emps": {
        "M": 95.11,
        "Fv": 0.0,
        "Fc": 0.0,
        "v_c": 0.001,
        "offset": 0.0,
        "gtau": 35.15,
        "kp": 160.18,
        "kv": 243.45,
        "vir_max": 10.0,
    },
}
CONTRACT_IO = {
    "tractor_implement": (
        ["delta"],
        ["gam_t", "gam_i", "psi_t", "psi_i", "v_tc", "x_tc", "y_tc", "x_ic", "y_ic"],
    ),
    "msd": (["f"], ["x", "v"]),
    "msd_parallel": (["f"], ["x", "v"]),
    "emps": (["q_ref", "f_ext"], ["qm", "vir", "v"]),
}


def test_all_builtin_models_are_built(built_fmus: dict[str, Path]) -> None:
    assert sorted(built_fmus) == sorted(BUILTIN_MODELS)


@pytest.mark.parametrize("name", BUILTIN_MODELS)
def test_fmpy_validation_finds_no_problem(built_fmus: dict[str, Path], name: str) -> None:
    assert validate_fmu(str(built_fmus[name])) == []


@pytest.mark.parametrize("name", BUILTIN_MODELS)
def test_variables_match_the_contract(built_fmus: dict[str, Path], name: str) -> None:
    model = FmuModel(built_fmus[name])
    assert model.model_name == name
    assert model.fmi_version == "2.0"
    assert len(model.sha256) == 64
    assert {k: v.start for k, v in model.parameters.items()} == CONTRACT_START[name]
    assert all(v.variability == "tunable" for v in model.parameters.values())
    inputs, outputs = CONTRACT_IO[name]
    assert list(model.inputs) == inputs
    assert sorted(model.outputs) == sorted(outputs)
    assert model.can_interpolate_inputs


@pytest.mark.parametrize("name", BUILTIN_MODELS)
def test_table_header_and_xml_agree(built_fmus: dict[str, Path], name: str) -> None:
    table = json.loads((model_src_dir() / name / "variables.json").read_text())
    model = FmuModel(built_fmus[name])
    with zipfile.ZipFile(built_fmus[name]) as archive:
        header = archive.read("sources/model_vars.h").decode()
    every = {**model.parameters, **model.inputs, **model.outputs}
    assert len(every) == len(table["variables"])
    for vr, entry in enumerate(table["variables"]):
        variable = every[entry["name"]]
        assert variable.value_reference == vr
        assert variable.causality == entry["causality"]
        assert variable.unit == entry.get("unit")
        assert variable.description == entry["description"]
        assert re.search(rf"\bVR_{entry['name']} = {vr}\b", header)
    assert f"#define N_STATES {len(table['states'])}" in header


def test_not_a_zip_is_rejected(tmp_path: Path) -> None:
    path = tmp_path / "bad.fmu"
    path.write_text("hello")
    with pytest.raises(FmuError, match="not a zip"):
        FmuModel(path)


def _rewrite(source: Path, target: Path, edit) -> Path:
    with zipfile.ZipFile(source) as src, zipfile.ZipFile(target, "w") as dst:
        for item in src.infolist():
            result = edit(item.filename, src.read(item.filename))
            if result is not None:
                dst.writestr(result[0], result[1])
    return target


def test_zip_slip_entry_is_rejected(msd_fmu: Path, tmp_path: Path) -> None:
    path = _rewrite(msd_fmu, tmp_path / "slip.fmu", lambda n, d: (n, d))
    with zipfile.ZipFile(path, "a") as archive:
        archive.writestr("../evil.txt", "x")
    with pytest.raises(FmuError, match="escapes"):
        FmuModel(path)


def test_wrong_fmi_version_is_rejected(msd_fmu: Path, tmp_path: Path) -> None:
    def edit(name: str, data: bytes):
        if name == "modelDescription.xml":
            data = data.replace(b'fmiVersion="2.0"', b'fmiVersion="1.0"')
        return name, data

    with pytest.raises(FmuError, match="1.0"):
        FmuModel(_rewrite(msd_fmu, tmp_path / "v1.fmu", edit))


def test_missing_interfaces_are_rejected(msd_fmu: Path, tmp_path: Path) -> None:
    def edit(name: str, data: bytes):
        if name == "modelDescription.xml":
            data = re.sub(rb"<CoSimulation[^>]*/>", b'<ModelExchange modelIdentifier="msd"/>', data)
        return name, data

    me_only = _rewrite(msd_fmu, tmp_path / "me.fmu", edit)
    assert FmuModel(me_only).interface == "ModelExchange"
    with pytest.raises(FmuError, match="no co_simulation interface"):
        FmuModel(me_only, interface="CoSimulation")

    def drop(name: str, data: bytes):
        if name == "modelDescription.xml":
            data = re.sub(rb"<CoSimulation[^>]*/>", b"", data)
        return name, data

    with pytest.raises(FmuError, match="neither a co-simulation nor a model-exchange"):
        FmuModel(_rewrite(msd_fmu, tmp_path / "none.fmu", drop))


def test_missing_linux_binary_is_rejected(msd_fmu: Path, tmp_path: Path) -> None:
    path = _rewrite(
        msd_fmu, tmp_path / "nobin.fmu", lambda n, d: None if n.startswith("binaries/") else (n, d)
    )
    with pytest.raises(FmuError, match="linux64"):
        FmuModel(path)


def test_compiler_error_raises_build_error_with_message(tmp_path: Path) -> None:
    src = tmp_path / "src"
    shutil.copytree(model_src_dir(), src)
    for other in ("tractor_implement", "msd_parallel"):
        shutil.rmtree(src / other)
    (src / "msd" / "model.c").write_text("this is not C;\n")
    with pytest.raises(BuildError, match="msd: gcc failed") as info:
        build_fmus(src, tmp_path / "out")
    assert "error" in str(info.value)


def test_missing_gcc_raises_build_error(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("PATH", str(tmp_path))
    with pytest.raises(BuildError, match="gcc was not found"):
        build_fmus(model_src_dir(), tmp_path / "out")


def test_builtin_fmu_builds_on_demand_and_rejects_unknown(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("FMUID_FMU_DIR", str(tmp_path / "fmus"))
    path = builtin_fmu("msd")
    assert path == tmp_path / "fmus" / "msd.fmu"
    assert FmuModel(path).model_name == "msd"
    with pytest.raises(FmuError, match="unknown built-in model 'nope'"):
        builtin_fmu("nope")
