"""One FMU world per process: the file read, its zip opened and its XML parsed once per FMU.

Counted twice: by the process's registry (``registry().parses``) and, independently, by
:class:`tests.model.spy.FmuSpy`, which wraps ``open``, ``zipfile.ZipFile`` and the XML parsers
of the standard library and lxml, whoever calls them (fmuid or fmpy).
"""

from __future__ import annotations

import multiprocessing
import os
import shutil
import threading
from pathlib import Path

import pytest
from tests.model.spy import FmuSpy

from fmuid.discrepancy.knowledge import read_annotations
from fmuid.engine.run import open_engine
from fmuid.model.annotations import planar_paths
from fmuid.model.fmu import FmuModel, load_model, model_of_file
from fmuid.model.registry import get_simulator, mark_reset_unreliable
from fmuid.model.world import open_registry, registry


def test_a_parse_reads_the_file_opens_its_zip_and_parses_its_xml_once(
    tractor_fmu: Path, tmp_path: Path
) -> None:
    """Simulators (one per thread) and the annotation's readers then read nothing again."""
    fmu = Path(shutil.copy(tractor_fmu, tmp_path / "copy.fmu"))
    with open_registry() as world, FmuSpy(fmu) as spy:
        model = FmuModel(fmu)
        assert spy.seen() == (1, 1, 1)
        assert world.parses == 1
        fmu.unlink()  # what follows cannot read the file
        here = get_simulator(model)
        there: list[object] = []
        thread = threading.Thread(target=lambda: there.append(get_simulator(model)))
        thread.start()
        thread.join()
        assert get_simulator(model) is here and there[0] is not here
        assert [p.label for p in planar_paths(model)] == ["tractor CG", "implement CG"]
        assert read_annotations(model).physics  # the tractor declares switchable physics
        assert spy.seen() == (1, 1, 1)
        assert world.parses == 1


def test_a_path_is_parsed_once_until_the_file_changes(msd_fmu: Path, tmp_path: Path) -> None:
    fmu = Path(shutil.copy(msd_fmu, tmp_path / "msd.fmu"))
    with open_registry() as world, FmuSpy(fmu) as spy:
        first = get_simulator(fmu)
        assert get_simulator(str(fmu)) is first
        assert load_model(first.model.file) is load_model(first.model.file)
        assert spy.seen() == (1, 1, 1) and world.parses == 1  # by path, then by checksum
        os.utime(fmu, ns=(0, 0))  # the file changed, as far as its stat tells: parsed again
        assert get_simulator(fmu) is first  # same checksum: the simulator stays
        assert world.parses == 2


def test_a_forked_child_keeps_the_models_and_verdicts_but_not_the_simulators(
    msd_fmu: Path,
) -> None:
    with open_registry():
        simulator = get_simulator(msd_fmu)
        model = simulator.model
        mark_reset_unreliable(model)
        queue = multiprocessing.get_context("fork").SimpleQueue()

        def child() -> None:
            world = registry()
            queue.put(
                (
                    world.parses,
                    get_simulator(msd_fmu).model is model,
                    world.reset_unreliable(model.key),
                    get_simulator(model) is simulator,
                    world.parses,
                )
            )

        process = multiprocessing.get_context("fork").Process(target=child)
        process.start()
        process.join(60)
        assert process.exitcode == 0
        parses, same_model, unreliable, same_simulator, parses_after = queue.get()
    assert (parses, same_model, unreliable, same_simulator, parses_after) == (
        0,
        True,
        True,
        False,
        0,
    )


def _in_worker(model: FmuModel) -> tuple[int, int, tuple[int, int, int]]:
    """In a pool worker: its parses, then what a simulator and a model's unpickling open."""
    with FmuSpy(model.path) as spy:
        get_simulator(model)
        load_model(model.file)
        return os.getpid(), registry().parses, spy.seen()


@pytest.mark.slow
def test_a_pool_worker_parses_the_fmu_once(msd_fmu: Path) -> None:
    """The worker parses in its set-up; the tasks' pickled models find that model."""
    model = FmuModel(msd_fmu)
    with open_engine(model, workers=2) as engine:
        seen = engine.map(_in_worker, [model] * 4)
    assert all(pid != os.getpid() for pid, _, _ in seen)
    assert {(parses, counts) for _, parses, counts in seen} == {(1, (0, 0, 0))}


def test_a_model_whose_file_is_gone_is_not_found_by_its_checksum(
    msd_fmu: Path, tmp_path: Path
) -> None:
    """A copy parsed and deleted, then the same bytes at another path: workers get that path."""
    gone = Path(shutil.copy(msd_fmu, tmp_path / "gone.fmu"))
    with open_registry() as world:
        model_of_file(gone)
        gone.unlink()
        here = model_of_file(msd_fmu)
        assert load_model(here.file).path == here.path
        assert world.parses == 2
