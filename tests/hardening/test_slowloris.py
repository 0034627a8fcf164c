"""Half-open connections (slowloris) neither exhaust the service's open files nor stall health,
and each is closed once its request head is late (``FMUID_HEADER_TIMEOUT_S``)."""

from __future__ import annotations

import resource
import socket
import time

import httpx
import pytest

pytestmark = pytest.mark.slow

CONNECTIONS = 1100
HEADER_TIMEOUT_S = 3


@pytest.fixture
def default_file_limit():
    """Start services with the common default soft limit of 1024 open files."""
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    resource.setrlimit(resource.RLIMIT_NOFILE, (min(1024, soft), hard))
    yield
    resource.setrlimit(resource.RLIMIT_NOFILE, (soft, hard))


def test_half_open_connections_leave_health_answering(service_factory, default_file_limit):
    if resource.getrlimit(resource.RLIMIT_NOFILE)[1] < 2 * CONNECTIONS:
        pytest.skip("the hard open-file limit leaves no room to raise")
    service = service_factory(FMUID_HEADER_TIMEOUT_S=str(HEADER_TIMEOUT_S))
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    resource.setrlimit(resource.RLIMIT_NOFILE, (hard, hard))  # room for this side's sockets
    half_open = []
    try:
        for _ in range(CONNECTIONS):
            sock = socket.create_connection(("127.0.0.1", service.port))
            sock.sendall(b"GET /v1/health HTTP/1.1\r\nHost: x\r\n")  # never finished
            half_open.append(sock)
        for _ in range(5):
            answer = httpx.get(service.url + "/v1/health", timeout=10)
            assert answer.status_code == 200, answer.text
        time.sleep(HEADER_TIMEOUT_S + 1)
        for sock in half_open:
            sock.settimeout(10)
            assert sock.recv(1) == b""  # the service closed it
    finally:
        for sock in half_open:
            sock.close()
        resource.setrlimit(resource.RLIMIT_NOFILE, (soft, hard))
    assert httpx.get(service.url + "/v1/health", timeout=10).status_code == 200
