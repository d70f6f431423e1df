"""A real service on a free port and a headless Chromium driving it (Debian's ``chromium`` and
``chromium-driver`` with Selenium). Used by the browser tests (their Chromium: the ``chromium_driver`` fixture of
tests/conftest.py) and ``scripts/dashboard_screenshots.py``."""

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


def require(what: str) -> None:
    """Skip the test, saying why no browser can run here, or fail it with CI=true, where it must run."""
    reason = missing()
    if reason and os.environ.get("CI", "").lower() == "true":
        pytest.fail(f"CI=true: the {what} must run, but {reason}")
    if reason:
        pytest.skip(f"no headless browser: {reason}")


@contextmanager
def page_on(app, driver) -> Iterator[tuple[str, object]]:
    """``app`` served on loopback and ``driver`` (the test process's shared Chromium) on a page as fresh as a new
    browser's: (base URL, driver). A browser starts in a second of CPU; a tab of its own per test is what isolates it."""
    with serve(app) as base:
        yield base, fresh_tab(driver)


def fresh_tab(driver):
    """``driver`` in a new tab, its other tabs closed and every cookie gone: scripts a test had Chromium inject
    into each new document (DevTools' addScriptToEvaluateOnNewDocument) belong to the tab it added them to, and a
    login cookie, kept per host whatever the port, would otherwise reach the next test's server."""
    earlier = list(driver.window_handles)
    driver.switch_to.new_window("tab")
    current = driver.current_window_handle
    for handle in earlier:
        driver.switch_to.window(handle)
        driver.close()
    driver.switch_to.window(current)
    driver.execute_cdp_cmd("Network.clearBrowserCookies", {})
    return driver


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
