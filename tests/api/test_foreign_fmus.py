"""Foreign FMUs over HTTP: FMI 3.0 co-simulation and FMI 2.0 model exchange VanDerPol, uploaded,
profiled by the real service, with the same interval as the Python API gives."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import fmuid
from fmuid.data import load_experiment, spec_from_json

REFERENCE_DIR = Path(
    os.environ.get(
        "FMUID_REFERENCE_FMUS", Path(__file__).resolve().parents[3] / "shared" / "reference-fmus"
    )
)
SPEC = {
    "parameters": {"mu": {"start": 1.0, "lower": 0.2, "upper": 4.0}},
    "outputs": {"x0": {"sigma": 0.02}},
    "global_search": False,
}


@pytest.fixture(scope="module")
def vdp_csv(tmp_path_factory: pytest.TempPathFactory) -> Path:
    t = np.round(np.arange(0.0, 10.0 + 1e-9, 0.2), 10)
    sol = solve_ivp(
        lambda _, x: [x[1], 1.3 * (1 - x[0] ** 2) * x[1] - x[0]],
        (0, 10),
        [2.0, 0.0],
        t_eval=t,
        rtol=1e-12,
        atol=1e-12,
        method="DOP853",
    )
    x0 = sol.y[0] + np.random.default_rng(1).normal(0.0, 0.02, t.size)
    path = tmp_path_factory.mktemp("vdp") / "vdp.csv"
    np.savetxt(path, np.column_stack([t, x0]), delimiter=",", header="time,x0", comments="")
    return path


@pytest.mark.parametrize("name", ["fmi3/VanDerPol.fmu", "fmi2/VanDerPol_ME_only.fmu"])
def test_profile_of_an_uploaded_foreign_fmu(service, vdp_csv: Path, name: str) -> None:
    fmu = REFERENCE_DIR / name
    if not fmu.is_file():
        pytest.skip(f"Reference-FMU {fmu} is absent (set FMUID_REFERENCE_FMUS to their folder)")
    client = service.client()
    job = client.submit("profile", json.dumps(SPEC), [vdp_csv], fmu_path=fmu)
    status = client.wait(job, timeout=600)
    assert status["status"] == "done", status
    remote = client.result(job)["parameters"]["mu"]["ci"]["pointwise"]
    local = fmuid.profile(
        fmu, [load_experiment(vdp_csv)], spec_from_json(json.dumps(SPEC)), workers=1
    ).parameters["mu"]
    np.testing.assert_allclose(remote, local.ci_pointwise, rtol=1e-6)
    if "ME_only" in name:  # CVode solves the exact ODE; the CS build steps with Euler (biased)
        assert remote[0] < 1.3 < remote[1]


def test_an_interface_the_fmu_lacks_is_422(service, vdp_csv: Path) -> None:
    from fmuid.client import ApiError

    fmu = REFERENCE_DIR / "fmi2" / "VanDerPol_ME_only.fmu"
    if not fmu.is_file():
        pytest.skip(f"Reference-FMU {fmu} is absent (set FMUID_REFERENCE_FMUS to their folder)")
    spec = json.dumps({**SPEC, "interface": "co_simulation"})
    with pytest.raises(ApiError) as error:
        service.client().submit("profile", spec, [vdp_csv], fmu_path=fmu)
    assert error.value.status_code == 422
    assert "interface: the FMU has no co_simulation interface (it has model_exchange)" in str(
        error.value
    )


def test_spec_interface_over_http(service, vdp_csv: Path) -> None:
    """A job whose spec asks for model exchange of an FMU that has both interfaces."""
    both = REFERENCE_DIR / "fmi2" / "VanDerPol.fmu"
    only_me = REFERENCE_DIR / "fmi2" / "VanDerPol_ME_only.fmu"
    if not (both.is_file() and only_me.is_file()):
        pytest.skip(f"Reference-FMUs absent in {REFERENCE_DIR} (set FMUID_REFERENCE_FMUS)")
    client = service.client()
    job = client.submit(
        "fit", json.dumps({**SPEC, "interface": "model_exchange"}), [vdp_csv], fmu_path=both
    )
    status = client.wait(job, timeout=600)
    assert status["status"] == "done", status
    remote = client.result(job)
    assert remote["fmu"]["interface"] == "ModelExchange"
    assert "CVode" in remote["fmu"]["input_handling"]
    local = fmuid.fit(only_me, [load_experiment(vdp_csv)], spec_from_json(json.dumps(SPEC)))
    assert remote["parameters"]["mu"]["estimate"] == pytest.approx(local.estimates["mu"], rel=1e-9)
