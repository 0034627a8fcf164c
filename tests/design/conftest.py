"""Fixtures of the design tests: the small msd study of ``design_cases``."""

from __future__ import annotations

import json

import pytest
from design_cases import MSD_SPEC, space_of

from fmuid.data import spec_from_json


@pytest.fixture
def msd_space():
    return space_of()


@pytest.fixture
def msd_spec():
    return spec_from_json(json.dumps(MSD_SPEC))
