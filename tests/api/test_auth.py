"""With FMUID_API_TOKEN set, every route but health refuses a missing or wrong token."""

from __future__ import annotations

import httpx
import pytest

ROUTES = [
    ("GET", "/v1/jobs"),
    ("POST", "/v1/jobs"),
    ("GET", "/v1/jobs/x"),
    ("GET", "/v1/jobs/x/result"),
    ("GET", "/v1/jobs/x/report"),
    ("GET", "/v1/jobs/x/report/a.png"),
    ("GET", "/v1/jobs/x/report-link"),
    ("GET", "/v1/jobs/x/report?sig=0123456789abcdef0123456789abcdef"),
    ("DELETE", "/v1/jobs/x"),
]


@pytest.fixture(scope="module")
def secured(tmp_path_factory):
    from api_helpers import Service

    svc = Service(tmp_path_factory.mktemp("secured"), FMUID_API_TOKEN="s3cret").start()
    yield svc
    svc.stop()


@pytest.mark.parametrize(("method", "path"), ROUTES)
@pytest.mark.parametrize("header", [None, "Bearer wrong", "Basic s3cret", "s3cret"])
def test_refused_without_the_token(secured, method, path, header):
    headers = {"Authorization": header} if header else {}
    response = httpx.request(method, secured.url + path, headers=headers)
    assert response.status_code == 401
    assert response.headers["WWW-Authenticate"].startswith("Bearer")
    assert "token" in response.json()["detail"]


def test_health_is_open_and_the_token_works(secured):
    assert httpx.get(secured.url + "/v1/health").status_code == 200
    ok = httpx.get(secured.url + "/v1/jobs", headers={"Authorization": "Bearer s3cret"})
    assert ok.status_code == 200
    missing = httpx.get(secured.url + "/v1/jobs/x", headers={"Authorization": "Bearer s3cret"})
    assert missing.status_code == 404
    schema = httpx.get(secured.url + "/openapi.json").json()
    assert schema["components"]["securitySchemes"]["bearer"]["scheme"] == "bearer"
    assert "security" not in schema["paths"]["/v1/health"]["get"]
