import functools
import http.server
import threading

import pytest

from fmuid.report import write_report
from plots.toy import toy_profile_result
from report.browser import check_report_page, chromium


@pytest.fixture
def served_report(tmp_path):
    result = toy_profile_result()
    index = write_report(result, tmp_path / "report")
    handler = functools.partial(http.server.SimpleHTTPRequestHandler, directory=str(index.parent))
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    yield f"http://127.0.0.1:{server.server_address[1]}/index.html", list(result.parameters)
    server.shutdown()
    server.server_close()


@pytest.mark.slow
def test_report_renders_in_chromium(served_report, tmp_path):
    url, parameters = served_report
    driver = chromium(tmp_path / "chromium-profile")
    try:
        check_report_page(driver, url, parameters, tmp_path / "report.png")
    finally:
        driver.quit()
