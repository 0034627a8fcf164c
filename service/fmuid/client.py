"""A small client of the fmuid HTTP API, for scripts and other tools.

>>> client = FmuidClient("http://127.0.0.1:8000", token=None)
>>> job = client.submit("profile", spec_text, ["step.csv"], model="msd")
>>> client.wait(job)["status"]
'done'
>>> result = client.result(job)
"""

from __future__ import annotations

import json
import time
from contextlib import ExitStack
from pathlib import Path
from typing import Any

import httpx

from fmuid.errors import FmuidError

FINAL = ("done", "failed", "cancelled")


class ApiError(FmuidError):
    """The service answered with an error status; ``status_code`` and ``detail`` say which."""

    def __init__(self, status_code: int, detail: str):
        super().__init__(f"HTTP {status_code}: {detail}")
        self.status_code = status_code
        self.detail = detail


class FmuidClient:
    """Client of one fmuid service.

    Parameters
    ----------
    base_url
        E.g. ``http://127.0.0.1:8000``.
    token
        The service's ``FMUID_API_TOKEN``, sent as ``Authorization: Bearer``.
    timeout
        Timeout of one HTTP request [s].

    """

    def __init__(self, base_url: str, token: str | None = None, timeout: float = 60.0):
        headers = {"Authorization": f"Bearer {token}"} if token else {}
        self.http = httpx.Client(base_url=base_url.rstrip("/"), headers=headers, timeout=timeout)

    def close(self) -> None:
        """Close the connection pool."""
        self.http.close()

    def __enter__(self) -> FmuidClient:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _call(self, method: str, path: str, **kwargs: Any) -> httpx.Response:
        response = self.http.request(method, path, **kwargs)
        if response.status_code >= 400:
            try:
                detail = response.json().get("detail", response.text)
            except ValueError:
                detail = response.text
            raise ApiError(response.status_code, str(detail))
        return response

    def submit(
        self,
        kind: str,
        spec: str | dict[str, Any],
        data_paths: list[str | Path],
        fmu_path: str | Path | None = None,
        model: str | None = None,
        space_path: str | Path | None = None,
    ) -> str:
        """Submit a job and return its id.

        Parameters
        ----------
        kind
            ``"fit"``, ``"profile"``, ``"diagnose"`` or ``"design"``.
        spec
            The spec as JSON text, or a dict to be sent as JSON.
        data_paths
            CSV files, one per experiment (their names become the experiment names).
        fmu_path, model
            An FMU file to upload, or the name of a built-in FMU (exactly one).
        space_path
            The experiment space JSON of a ``"design"`` job (which takes no CSV files).

        Raises
        ------
        ApiError
            With status 413 (too large) or 422 (bad input) and the service's reason.

        """
        text = spec if isinstance(spec, str) else json.dumps(spec)
        form = {"kind": kind, "spec": text}
        if model is not None:
            form["model"] = model
        with ExitStack() as stack:
            files = [
                ("data", (Path(p).name, stack.enter_context(open(p, "rb")), "text/csv"))
                for p in data_paths
            ]
            if fmu_path is not None:
                stream = stack.enter_context(open(fmu_path, "rb"))
                files.append(("fmu", (Path(fmu_path).name, stream, "application/zip")))
            if space_path is not None:
                stream = stack.enter_context(open(space_path, "rb"))
                files.append(("space", (Path(space_path).name, stream, "application/json")))
            response = self._call("POST", "/v1/jobs", data=form, files=files)
        job_id: str = response.json()["id"]
        return job_id

    def status(self, job_id: str) -> dict[str, Any]:
        """Return the job's status, progress and error."""
        status: dict[str, Any] = self._call("GET", f"/v1/jobs/{job_id}").json()
        return status

    def wait(self, job_id: str, timeout: float = 3600.0, poll: float = 0.5) -> dict[str, Any]:
        """Poll until the job is done, failed or cancelled; return its last status.

        Raises
        ------
        TimeoutError
            If it is still queued or running after ``timeout`` seconds.

        """
        deadline = time.monotonic() + timeout
        while True:
            status = self.status(job_id)
            if status["status"] in FINAL:
                return status
            if time.monotonic() > deadline:
                raise TimeoutError(f"job {job_id} still {status['status']} after {timeout} s")
            time.sleep(poll)

    def result(self, job_id: str) -> dict[str, Any]:
        """Return the result JSON of a done job (:class:`ApiError` 409 while not done)."""
        result: dict[str, Any] = self._call("GET", f"/v1/jobs/{job_id}/result").json()
        return result

    def cancel(self, job_id: str) -> dict[str, Any]:
        """Cancel a job; return its status."""
        status: dict[str, Any] = self._call("DELETE", f"/v1/jobs/{job_id}").json()
        return status

    def report(self, job_id: str) -> str:
        """Return the HTML report of a done job."""
        return self._call("GET", f"/v1/jobs/{job_id}/report").text

    def report_url(self, job_id: str) -> str:
        """Return the address that opens a job's report in a browser (signed when a token is set).

        The browser sends no token; the signature in the address opens this one report.
        """
        path: str = self._call("GET", f"/v1/jobs/{job_id}/report-link").json()["url"]
        return f"{self.http.base_url}".rstrip("/") + path

    def list(self, limit: int = 100) -> list[dict[str, Any]]:
        """Return jobs, newest first."""
        jobs: list[dict[str, Any]] = self._call("GET", "/v1/jobs", params={"limit": limit}).json()[
            "jobs"
        ]
        return jobs

    def health(self) -> dict[str, Any]:
        """Return liveness and queue depth."""
        health: dict[str, Any] = self._call("GET", "/v1/health").json()
        return health
