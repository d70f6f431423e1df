"""Security headers: every HTML page (dashboard, login, errors, docs) carries a Content-Security-Policy that
admits no injected script, X-Frame-Options: DENY, X-Content-Type-Options: nosniff and a Referrer-Policy; the
docs still run under it with their packaged assets (checked in a real browser when one is installed)."""

from __future__ import annotations

import base64
import hashlib
import re

import pytest
from fastapi.testclient import TestClient
from starlette.applications import Starlette
from starlette.responses import Response
from starlette.routing import Route

from plantsolve.app.main import create_app
from plantsolve.app.middleware import secured
from tests.conftest import service_settings
from tests.support import browser

ALICE = {"Authorization": "Bearer key-a"}


@pytest.fixture
def client(tmp_path):
    with TestClient(create_app(service_settings(tmp_path, api_keys=["alice:key-a"]), run_jobs=False)) as client:
        yield client


def _policy(response) -> dict[str, list[str]]:
    directives = [d.split() for d in response.headers["content-security-policy"].split(";") if d.strip()]
    return {d[0]: d[1:] for d in directives}


def _assert_page_headers(response, path: str) -> dict[str, list[str]]:
    assert response.headers["content-type"].startswith("text/html"), path
    assert response.headers["x-frame-options"] == "DENY", path
    assert response.headers["x-content-type-options"] == "nosniff", path
    assert response.headers["referrer-policy"] == "no-referrer", path
    policy = _policy(response)
    assert policy["frame-ancestors"] == ["'none'"] and policy["object-src"] == ["'none'"], path
    assert "'unsafe-inline'" not in policy["script-src"] and "'unsafe-eval'" not in policy["script-src"], path
    assert policy["default-src"] == ["'self'"] and policy["base-uri"] == ["'none'"], path
    return policy


def test_every_html_page_carries_the_security_headers(client):
    job = client.post("/v1/test-compute/jobs", json={"values": [1.0]}, headers=ALICE).json()
    pages = {"/dashboard/login": {}, "/dashboard": ALICE, f"/dashboard/jobs/{job['id']}": ALICE,
             "/dashboard/jobs/00000000-0000-0000-0000-000000000000": ALICE, "/dashboard/submit/test-compute": ALICE,
             "/redoc": ALICE, "/docs": ALICE, "/docs/oauth2-redirect": ALICE}
    for path, headers in pages.items():
        response = client.get(path, headers=headers)
        assert response.status_code in (200, 404), path
        policy = _assert_page_headers(response, path)
        inline = re.findall(r"<script>(.*?)</script>", response.text, re.DOTALL)
        hashes = [f"'sha256-{base64.b64encode(hashlib.sha256(s.encode()).digest()).decode()}'" for s in inline]
        # exactly the page's own inline scripts are admitted (the docs' bootstrap), nothing else inline
        assert policy["script-src"] == ["'self'", *hashes], path
        assert bool(hashes) == path.startswith("/docs"), path
    api = client.get("/v1/jobs", headers=ALICE)  # JSON: not a page, but never sniffed into one
    assert api.headers["x-content-type-options"] == "nosniff" and "x-frame-options" not in api.headers
    refused = client.get("/dashboard/rows")  # a refusal before any route carries them too
    assert refused.status_code == 401 and refused.headers["x-content-type-options"] == "nosniff"


def test_an_svg_opened_on_its_own_runs_nothing():
    svg = b'<svg xmlns="http://www.w3.org/2000/svg"><script>alert(1)</script></svg>'
    inner = Starlette(routes=[Route("/plot.svg", lambda request: Response(svg, media_type="image/svg+xml"))])

    async def app(scope, receive, send):
        await inner(scope, receive, secured(scope, send))

    response = TestClient(app).get("/plot.svg")
    assert response.content == svg
    assert "sandbox" in _policy(response) and _policy(response)["default-src"] == ["'none'"]


# ---- in a real browser: the pages work under their policy ------------------------------------------------

VIOLATIONS = """window.__csp = [];
document.addEventListener('securitypolicyviolation',
  e => window.__csp.push(e.violatedDirective + ' ' + e.blockedURI));"""


@pytest.fixture
def site(tmp_path, chromium_driver):
    app = create_app(service_settings(tmp_path, api_keys=["alice:key-a"], protect_docs=False))
    with browser.page_on(app, chromium_driver) as (base, driver):
        driver.execute_cdp_cmd("Page.addScriptToEvaluateOnNewDocument", {"source": VIOLATIONS})
        yield base, driver


def _blocked_here(driver, base: str) -> list[str]:
    """The page's violations except requests to other sites, which the policy is meant to stop (ReDoc's
    "powered by" logo comes from its CDN)."""
    outside = ("http://", "https://")
    return [v for v in driver.execute_script("return window.__csp")
            if not (v.split(" ", 1)[-1].startswith(outside) and not v.split(" ", 1)[-1].startswith(base))]


def test_docs_and_dashboard_work_under_their_policy_in_a_browser(site):
    from selenium.webdriver.common.by import By
    from selenium.webdriver.support.ui import WebDriverWait

    base, driver = site
    wait = WebDriverWait(driver, 30, poll_frequency=0.1)
    driver.get(f"{base}/docs")  # Swagger UI: packaged bundle, inline bootstrap admitted by its hash
    wait.until(lambda d: d.find_elements(By.CSS_SELECTOR, ".swagger-ui .info .title"))
    assert "plantsolve" in driver.find_element(By.CSS_SELECTOR, ".swagger-ui .info .title").text
    wait.until(lambda d: d.find_elements(By.CSS_SELECTOR, ".opblock"))  # the spec was fetched and rendered
    assert _blocked_here(driver, base) == []
    driver.get(f"{base}/redoc")  # ReDoc: packaged bundle, its styles
    wait.until(lambda d: d.find_elements(By.CSS_SELECTOR, "h1") and "plantsolve" in d.find_element(By.CSS_SELECTOR, "h1").text)
    wait.until(lambda d: d.find_elements(By.CSS_SELECTOR, "[data-section-id]"))  # the operations were rendered
    assert _blocked_here(driver, base) == []
    driver.get(f"{base}/dashboard/login")
    driver.find_element(By.NAME, "key").send_keys("key-a")
    driver.find_element(By.CSS_SELECTOR, "form.login button").click()
    wait.until(lambda d: d.current_url.rstrip("/").endswith("/dashboard"))
    wait.until(lambda d: d.find_element(By.TAG_NAME, "body").get_attribute("data-transport"))  # its script ran
    assert _blocked_here(driver, base) == []
    # an injected inline script would be refused: the policy is in force, not just sent
    driver.execute_script("var s = document.createElement('script'); s.textContent = 'window.__ran = 1';"
                          "document.body.appendChild(s);")
    assert driver.execute_script("return window.__ran") is None
    assert any(v.startswith("script-src") for v in driver.execute_script("return window.__csp"))
