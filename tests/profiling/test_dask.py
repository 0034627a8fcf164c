"""Profile branches on a dask.distributed cluster give the local pool's intervals."""

import pickle
import shutil

import numpy as np
import pytest

import fmuid
from fmuid.engine.cluster import PickledTask, execute_anywhere
from fmuid.estimation.optimize import fit_problem
from fmuid.profiling.branch import BranchTask
from fmuid.profiling.engine import thresholds
from fmuid.profiling.walk import WalkOptions
from fmuid.stages import make_problem

from .test_msd import msd_step_data, spec

TRUTH = {"m": 1.1, "k": 4.4, "b": 1.6}


@pytest.mark.slow
def test_dask_local_cluster_matches_local_pool(msd_fmu):
    from distributed import Client, LocalCluster

    data = msd_step_data(**TRUTH, sigma=0.3, seed=5)
    s = spec(TRUTH, 0.3)
    local = fmuid.profile(msd_fmu, [data], s, workers=2)
    with LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0"
    ) as cluster:
        with Client(cluster) as client:
            remote = fmuid.profile(msd_fmu, [data], s, executor=client)
    for name, p in local.parameters.items():
        q = remote.parameters[name]
        assert q.ci_simultaneous == pytest.approx(p.ci_simultaneous, rel=1e-9)
        assert q.status == p.status


def test_branch_runs_from_fmu_bytes_when_the_file_is_not_there(msd_fmu, tmp_path):
    """A remote worker that cannot see the FMU path uses the bytes sent with the work."""
    copy = tmp_path / "moved.fmu"
    shutil.copy(msd_fmu, copy)
    data = msd_step_data(**TRUTH, sigma=0.3, seed=6)
    problem = make_problem(copy, [data], spec(TRUTH, 0.3))
    fit = fit_problem(problem, global_search=False)
    blob = copy.read_bytes()
    copy.unlink()
    thr = thresholds(0.68, 3)["simultaneous"]
    task = BranchTask(
        problem, fit.z_estimate(), fit.chi2, 0, 1, thr, fit.fisher_sd_z()["m"], WalkOptions()
    )
    sent = PickledTask(problem.model.file, pickle.dumps(task))
    result, walked = execute_anywhere(sent, problem.model.sha256, blob)
    assert walked == sorted(walked) and walked[-1] >= 3  # the progress comes back with it
    assert len(result.points) >= 3
    assert all(p.error is None for p in result.points)
    assert result.points[-1].chi2 - fit.chi2 > thr
    assert np.all(np.diff([p.z[0] for p in result.points]) > 0)
