"""The task engine: run independent tasks in this process, in local workers or on dask.

A task (:class:`~fmuid.engine.task.Task`) is a picklable object with ``execute(report)``;
``report`` carries its progress events back to the owner, whatever runs it. The engines know
nothing of profiles, designs or diagnoses (pyPESTO's ``engine/``):

- :class:`~fmuid.engine.local.SerialEngine`: one task after the other, in this process;
- :class:`~fmuid.engine.local.PoolEngine`: forkserver worker processes that die with their
  owner and stop at once on Ctrl-C (:mod:`fmuid.engine.pool`);
- :class:`~fmuid.engine.cluster.DaskEngine`: tasks of a ``dask.distributed.Client``, each
  carrying the FMU's bytes for a worker that cannot see its file.

:func:`fmuid.engine.run.open_engine` picks one. This package imports nothing at its top, so
that a forkserver preloading :mod:`fmuid.engine.forkserver_guard` starts light.
"""
