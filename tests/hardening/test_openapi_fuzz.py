"""Schemathesis against the service's own ``/openapi.json``: no 5xx, every answer as declared.

Each operation of the schema gets a bounded number of generated requests (positive and negative
data) sent to a real service process with a real worker; every answer goes through all of
schemathesis's checks (server error, status code, content type, headers, response schema, ...).
"""

from __future__ import annotations

import tempfile

import pytest
import schemathesis
from hypothesis import HealthCheck, given, settings
from schemathesis.checks import CheckFunction
from schemathesis.specs.openapi.checks import positive_data_acceptance

from api_helpers import Service
from fmuid.api import create_app
from fmuid.settings import Settings

pytestmark = pytest.mark.slow

EXAMPLES = 40
# A schema-valid submission is still refused (422) unless its spec is JSON naming the FMU's
# variables and its files are CSV that fit it, which no JSON schema can say: the check that
# schema-valid requests are accepted does not apply to ``POST /v1/jobs``.
NOT_APPLICABLE: dict[tuple[str, str], list[CheckFunction]] = {
    ("/v1/jobs", "POST"): [positive_data_acceptance]
}


def _operations() -> list[tuple[str, str]]:
    with tempfile.TemporaryDirectory() as tmp:
        paths = create_app(Settings(data_dir=tmp)).openapi()["paths"]
    return [(path, method.upper()) for path, ops in paths.items() for method in ops]


@pytest.fixture(scope="module")
def api_schema(service: Service) -> schemathesis.schemas.BaseSchema:
    return schemathesis.openapi.from_url(service.url + "/openapi.json")


@pytest.mark.parametrize(("path", "method"), _operations())
def test_operation_conforms_to_its_schema(
    api_schema: schemathesis.schemas.BaseSchema, service: Service, path: str, method: str
) -> None:
    operation = api_schema[path][method]

    @given(case=operation.as_strategy())
    @settings(max_examples=EXAMPLES, deadline=None, suppress_health_check=list(HealthCheck))
    def check(case: schemathesis.Case) -> None:
        case.call_and_validate(
            base_url=service.url,
            timeout=60,
            excluded_checks=NOT_APPLICABLE.get((path, method), []),
        )

    check()
    assert service.client().health()["status"] == "ok"
