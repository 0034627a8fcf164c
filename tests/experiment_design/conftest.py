"""Fixtures of the design tests: the small msd study of ``design_cases``."""

from __future__ import annotations

import json

import pytest

from design_cases import MSD_SPEC, SMALL, space_of
from fmuid.data import spec_from_json
from fmuid.experiment_design import design


@pytest.fixture
def msd_space():
    return space_of()


@pytest.fixture(scope="session")
def msd_spec():
    return spec_from_json(json.dumps(MSD_SPEC))


@pytest.fixture(scope="session")
def serial(msd_spec):
    """The small study (``SMALL``) evaluated in this process, without a checkpoint."""
    return design("msd", msd_spec, space_of(**SMALL))
