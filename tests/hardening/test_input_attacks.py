"""Hostile uploads get a 4xx naming the limit, and health answers within 100 ms throughout.

Each attack is posted to a real service while a process polls ``/v1/health`` every 10 ms, and
the slowest of those answers must stay under 100 ms. The bound is asserted as such when the
machine is quiet enough for it to mean something: the idle service, measured for 1 s just before
each attack, answered every poll within 30 ms and the load is under 1 per core (``QUIET_S``,
``QUIET_LOAD`` in conftest). On a loaded machine (a shared CI runner, where the scheduler alone
delays an idle service by up to ~0.1 s) the attack may add at most 100 ms to twice the idle
worst instead; an upload parsed in the service held health for 5-30 s, which fails either
bound. Both numbers are recorded in the test report (``record_property``), and
``bench/load.py`` prints health latency under load. The attacks: a
number cell that makes a backtracking pattern take minutes, a 20k-column header, a spec with 20k
keys, a spec nested 100k deep, an FMU whose modelDescription lists a million variables (and one
just over the variable limit), an FMU with a corrupt member, and FMUs whose binary sleeps or
forks when loaded (checked by their probe in its own process group, killed afterwards).
"""

from __future__ import annotations

import json
import subprocess
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest

from api_helpers import Service, msd_csv, rewrite_fmu
from attacks import (
    GOOD_CSV,
    MSD_SPEC,
    HealthWatch,
    big_model_description,
    corrupt_member,
    deep_spec,
    many_keys_spec,
    post_job,
    redos_csv,
    wide_csv,
)

pytestmark = pytest.mark.slow

PROBE_TIMEOUT_S = 2
FORKED_NAME = "fmuidforked"
LOAD_HOOK = r"""
#include <sys/prctl.h>
#include <unistd.h>
__attribute__((constructor)) static void on_load(void) {
#ifdef FORK
    if (fork() == 0) { prctl(PR_SET_NAME, "@NAME@", 0, 0, 0); sleep(600); _exit(0); }
#else
    sleep(600);
#endif
}
""".replace("@NAME@", FORKED_NAME)


@pytest.fixture
def health_bound(attacked, health_bound_of):
    """The bound, from the idle service's slowest health answer over the 1 s before the attack."""
    return health_bound_of(attacked.url)


@pytest.fixture(scope="module")
def attacked(tmp_path_factory: pytest.TempPathFactory):
    """A service with a short probe time, a raised cell limit (so the pattern itself is tried)."""
    service = Service(
        tmp_path_factory.mktemp("attacked"),
        FMUID_PROBE_TIMEOUT_S=str(PROBE_TIMEOUT_S),
        FMUID_MAX_CELL_CHARS="200000",
        FMUID_MAX_MODEL_VARIABLES="1000",
    ).start()
    yield service
    service.stop()


def attack(service, bound, spec: str, csv: bytes, fmu: Path | None = None) -> str:
    """Post under watch; assert a 422 and health within 100 ms; return the reason."""
    with HealthWatch(service.url) as watch:
        response = post_job(service.url, spec, csv, fmu, timeout=120)
    assert response.status_code == 422, response.text
    bound.check(watch)
    return response.json()["detail"]


SPEC = json.dumps(MSD_SPEC)
CASES = {
    "backtracking-cell": (SPEC, redos_csv(100_000), "row 3, column 'x': text '1111"),
    "20k-columns": (SPEC, wide_csv(20_000), "limit of 1000 columns (FMUID_MAX_CSV_COLUMNS)"),
    "20k-keys": (many_keys_spec(20_000), GOOD_CSV, "limit of 10000 keys (FMUID_MAX_SPEC_KEYS)"),
    "deep-nesting": (deep_spec(100_000), GOOD_CSV, "nested arrays and objects (FMUID_MAX_SPEC"),
    "5000-digit-number": (
        SPEC.replace('"start": 1.1', '"start": 1' + "1" * 4999),
        GOOD_CSV,
        "spec: a number of 5000 characters, more than the limit of 100",
    ),
}


@pytest.mark.parametrize(("spec", "csv", "needle"), CASES.values(), ids=CASES.keys())
def test_hostile_text_is_refused_naming_the_limit(attacked, health_bound, spec, csv, needle):
    assert needle in attack(attacked, health_bound, spec, csv)


def test_million_variable_model_description(attacked, health_bound, msd_file, tmp_path):
    fmu = big_model_description(msd_file, tmp_path / "big.fmu", 1_000_000)
    reason = attack(attacked, health_bound, SPEC, GOOD_CSV, fmu)
    assert reason.startswith("big.fmu: modelDescription.xml unpacks to")
    assert "(FMUID_MAX_MODEL_DESCRIPTION_BYTES)" in reason


def test_variables_over_the_limit(attacked, health_bound, msd_file, tmp_path):
    fmu = big_model_description(msd_file, tmp_path / "many.fmu", 1_000)
    reason = attack(attacked, health_bound, SPEC, GOOD_CSV, fmu)
    assert "more than the limit of 1000 variables (FMUID_MAX_MODEL_VARIABLES)" in reason


def test_corrupt_member(attacked, health_bound, msd_file, tmp_path):
    fmu = corrupt_member(msd_file, tmp_path / "bad.fmu")
    reason = attack(attacked, health_bound, SPEC, GOOD_CSV, fmu)
    assert reason.startswith("bad.fmu: ") and "corrupt" in reason


def hooked_fmu(msd_file: Path, target: Path, fork: bool) -> Path:
    """The msd FMU whose binary is replaced by one that sleeps (or forks a sleeper) on load."""
    source = target.with_suffix(".c")
    source.write_text(LOAD_HOOK)
    binary = target.with_suffix(".so")
    flags = ["-DFORK"] if fork else []
    subprocess.run(["gcc", "-shared", "-fPIC", *flags, "-o", binary, source], check=True)
    return rewrite_fmu(msd_file, target, {"binaries/linux64/msd.so": binary.read_bytes()})


def forked_sleepers() -> list[str]:
    found = []
    for comm in Path("/proc").glob("[0-9]*/comm"):
        try:
            if comm.read_text().strip() == FORKED_NAME:
                found.append(comm.parent.name)
        except OSError:
            pass
    return found


def test_sleeping_binaries_do_not_stall_the_service(attacked, health_bound, msd_file, tmp_path):
    fmu = hooked_fmu(msd_file, tmp_path / "sleeper.fmu", fork=False)
    with HealthWatch(attacked.url) as watch, ThreadPoolExecutor(4) as pool:
        responses = list(pool.map(lambda _: post_job(attacked.url, SPEC, GOOD_CSV, fmu), range(4)))
        polls = [attacked.client().list() for _ in range(3)]
    health_bound.check(watch)
    assert all(poll == [] for poll in polls)
    for response in responses:
        assert response.status_code == 422, response.text
        detail = response.json()["detail"]
        assert f"did not finish within {PROBE_TIMEOUT_S} s (FMUID_PROBE_TIMEOUT_S)" in detail


def test_forking_binary_leaves_no_process(attacked, health_bound, msd_file, tmp_path):
    fmu = hooked_fmu(msd_file, tmp_path / "forker.fmu", fork=True)
    reason = attack(attacked, health_bound, SPEC, GOOD_CSV, fmu)
    assert "does not export fmi2GetVersion" in reason
    deadline = time.monotonic() + 5
    while forked_sleepers() and time.monotonic() < deadline:
        time.sleep(0.1)
    assert forked_sleepers() == []


def test_good_submission_after_the_attacks(attacked, tmp_path):
    client = attacked.client()
    csv = msd_csv(tmp_path / "step.csv")
    job = client.submit("fit", SPEC, [csv], model="msd")
    assert client.wait(job, timeout=300)["status"] == "done"


def processes_of(data_dir: Path) -> list[str]:
    """Processes started for the service whose data folder is ``data_dir`` (by environment)."""
    marker = f"FMUID_DATA_DIR={data_dir}".encode()
    found = []
    for environ in Path("/proc").glob("[0-9]*/environ"):
        try:
            if marker in environ.read_bytes().split(b"\0"):
                found.append(environ.parent.name)
        except OSError:
            pass
    return found


def test_checks_are_bounded_in_number_and_time(service_factory, msd_file, step_csv, tmp_path):
    service = service_factory(
        FMUID_CHECK_WORKERS="1",
        FMUID_CHECK_WAIT_S="1",
        FMUID_CHECK_TIMEOUT_S="2",
        FMUID_PROBE_TIMEOUT_S="60",
    )
    client = service.client()
    warm = client.submit("fit", SPEC, [step_csv], model="msd")
    fmu = hooked_fmu(msd_file, tmp_path / "sleeper.fmu", fork=False)
    with ThreadPoolExecutor(2) as pool:
        responses = list(pool.map(lambda _: post_job(service.url, SPEC, GOOD_CSV, fmu), range(2)))
    by_status = {r.status_code: r.json()["detail"] for r in responses}
    assert set(by_status) == {422, 503}, by_status
    assert "took longer than 2 s (FMUID_CHECK_TIMEOUT_S)" in by_status[422]
    assert "(FMUID_CHECK_WAIT_S)" in by_status[503]
    assert client.wait(warm, timeout=300)["status"] == "done"
    service.kill()
    deadline = time.monotonic() + 5
    while processes_of(service.data_dir) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert processes_of(service.data_dir) == []
