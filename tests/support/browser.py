"""A real service on a free port and a headless Chromium driving it (Debian's ``chromium`` and
``chromium-driver`` with Selenium). Used by the browser test and ``scripts/dashboard_screenshots.py``."""

from __future__ import annotations

import os
import shutil
import tempfile
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator

import pytest

from tests.support.live import live_server

CHROMIUM = "/usr/bin/chromium"
CHROMEDRIVER = "/usr/bin/chromedriver"


def missing() -> str | None:
    """Why no browser test can run here, or None."""
    for path in (CHROMIUM, CHROMEDRIVER):
        if not Path(path).exists():
            return f"{path} is missing (apt-get install chromium chromium-driver)"
    try:
        import selenium  # noqa: F401
    except ImportError:
        return "selenium is not installed (pip install -e '.[test]')"
    return None


@contextmanager
def page_on(app, what: str) -> Iterator[tuple[str, object]]:
    """``app`` served on loopback and a headless Chromium (20 s page loads) to drive it: (base URL, driver).
    Without a browser the test is skipped with the reason, or fails with CI=true, where it must run."""
    reason = missing()
    if reason and os.environ.get("CI", "").lower() == "true":
        pytest.fail(f"CI=true: the {what} must run, but {reason}")
    if reason:
        pytest.skip(f"no headless browser: {reason}")
    with serve(app) as base, chromium() as driver:
        driver.set_page_load_timeout(20)
        yield base, driver


def serve(app):
    """Run ``app`` with uvicorn in a thread; a context that yields its base URL."""
    return live_server(app)


@contextmanager
def chromium(width: int = 1400, height: int = 1000) -> Iterator:
    """A headless Chromium with a fresh profile that talks to nothing but the pages it is sent to
    (no Selenium Manager download: the driver and the browser are the system's)."""
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    profile = tempfile.mkdtemp(prefix="plantsolve-chromium-")
    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for flag in ("--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                 "--disable-background-networking", "--disable-component-update", "--disable-sync",
                 "--disable-dev-shm-usage", f"--user-data-dir={profile}", f"--window-size={width},{height}"):
        options.add_argument(flag)
    driver = webdriver.Chrome(service=Service(CHROMEDRIVER), options=options)
    try:
        yield driver
    finally:
        driver.quit()
        shutil.rmtree(profile, ignore_errors=True)
