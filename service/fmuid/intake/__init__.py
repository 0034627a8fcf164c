"""Intake: what checks a job's upload and stages its inputs.

The archive check and the probe of an uploaded FMU (:mod:`~fmuid.intake.fmucheck`,
:mod:`~fmuid.intake.probe_fmu`), the checking processes and their pool
(:mod:`~fmuid.intake.vet`, :mod:`~fmuid.intake.pool`), the submission that stores and queues
a checked upload (:mod:`~fmuid.intake.submission`) and the one loader of a stored job's inputs
(:mod:`~fmuid.intake.inputs`). The upload is held to the same study check the engine runs
(:func:`fmuid.estimation.study.check_study`).
"""
