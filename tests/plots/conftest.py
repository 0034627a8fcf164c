import pytest

from fmuid.profiling.result import ProfileResult
from plots.toy import toy_profile_result


@pytest.fixture
def profile_result() -> ProfileResult:
    return toy_profile_result()
