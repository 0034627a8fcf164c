"""Headless Chromium (Debian ``chromium`` + ``chromium-driver``) driven by Selenium."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

CHROMIUM = Path("/usr/bin/chromium")
CHROMEDRIVER = Path("/usr/bin/chromedriver")
FLAGS = (
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--window-size=1300,2000",
)


def chromium(profile_dir: Path):
    """Start headless Chromium with a fresh profile; skip the test when it is not installed."""
    webdriver = pytest.importorskip("selenium.webdriver")
    driver = CHROMEDRIVER if CHROMEDRIVER.exists() else shutil.which("chromedriver")
    if not CHROMIUM.exists() or not driver:
        pytest.skip(
            f"no {CHROMIUM} or chromedriver: install Debian's chromium and chromium-driver "
            "(bash scripts/setup.sh --test)"
        )
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = str(CHROMIUM)
    for flag in FLAGS:
        options.add_argument(flag)
    options.add_argument(f"--user-data-dir={profile_dir}")
    return webdriver.Chrome(options=options, service=Service(str(driver)))


def check_report_page(driver, url: str, parameters: list[str], screenshot: Path) -> None:
    """Open ``url``, wait for the images, check them and the summary table, save a screenshot."""
    from selenium.webdriver.common.by import By
    from selenium.webdriver.support.ui import WebDriverWait

    driver.get(url)
    WebDriverWait(driver, 30).until(
        lambda d: d.execute_script(
            "return document.readyState === 'complete' && "
            "Array.from(document.images).every(i => i.complete)"
        )
    )
    widths = driver.execute_script("return Array.from(document.images).map(i => i.naturalWidth)")
    assert widths, "the report shows no image"
    assert all(w > 0 for w in widths), f"images that did not load: {widths}"
    rows = driver.find_elements(By.CSS_SELECTOR, "table#summary tr td:first-child")
    assert [r.text for r in rows] == parameters
    driver.save_screenshot(str(screenshot))
    assert screenshot.stat().st_size > 0
