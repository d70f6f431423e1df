"""The dashboard in a real headless browser against the real service (uvicorn, SQLite in tmp_path):
log in, submit a perfmap job through the form, watch its page reach 'succeeded' without a reload,
find the plots loaded, then the list with the job's warning count, a filter and a live new row.

Needs Debian's ``chromium`` and ``chromium-driver`` (``.ci/run`` installs them); skipped with the
reason when they are missing, except with CI=true, where that is a failure."""

from __future__ import annotations

import json
import re

import httpx
import pytest

from plantsolve.app.main import create_app
from plantsolve.solvers.kinds import KINDS
from tests.conftest import REPO, service_settings
from tests.support import browser

KEY = "key-a"
FAN_MAP = REPO / "examples" / "perfmap" / "n3_fan_map.csv"


@pytest.fixture
def site(tmp_path, chromium_driver):
    app = create_app(service_settings(tmp_path, api_keys=[f"alice:{KEY}"]))
    with browser.page_on(app, chromium_driver) as (base, driver):
        yield app, base, driver


def _has_route(app, path: str) -> bool:
    return path in app.openapi()["paths"]


def test_submit_watch_and_list_in_a_browser(site):
    from selenium.common.exceptions import StaleElementReferenceException
    from selenium.webdriver.common.by import By
    from selenium.webdriver.support.ui import Select, WebDriverWait

    app, base, driver = site
    wait = WebDriverWait(driver, 120, poll_frequency=0.1, ignored_exceptions=(StaleElementReferenceException,))
    api = httpx.Client(base_url=base, headers={"Authorization": f"Bearer {KEY}"}, timeout=10)
    other = api.post("/v1/test-compute/jobs", json={"values": [1.0, 2.0]}).json()  # a second kind for the filter

    # the cookie login, then the form: the upload with the options at their defaults (prefilled)
    driver.get(f"{base}/dashboard")
    assert driver.current_url.endswith("/dashboard/login")
    _login(driver, base)
    wait.until(lambda d: d.current_url.rstrip("/").endswith("/dashboard"))
    driver.get(f"{base}/dashboard/submit/perfmap")
    form = driver.find_element(By.ID, "upload-form")
    shown = json.loads(form.find_element(By.NAME, "options").get_attribute("value"))
    assert shown == json.loads(form.find_element(By.NAME, "option_defaults").get_attribute("value"))
    form.find_element(By.NAME, "file").send_keys(str(FAN_MAP))
    form.find_element(By.CSS_SELECTOR, "button[type=submit]").click()

    wait.until(lambda d: "/dashboard/jobs/" in d.current_url)
    job_id = re.search(r"/dashboard/jobs/([0-9a-f-]{36})", driver.current_url).group(1)
    driver.execute_script("window.sameDocument = true;")  # gone if the page were reloaded
    wait.until(lambda d: d.find_element(By.CSS_SELECTOR, "#job-detail [data-field=status]").text == "succeeded")
    assert driver.execute_script("return window.sameDocument === true;"), "the page reloaded instead of updating"
    transport = driver.find_element(By.TAG_NAME, "body").get_attribute("data-transport")
    expected = "events" if _has_route(app, "/v1/jobs/{job_id}/events") else "polling"
    assert transport == expected, f"followed by {transport!r}, expected {expected!r}"

    view = api.get(f"/v1/jobs/{job_id}").json()
    warnings = len(view["report"]["warnings"])
    pngs = sorted(a["name"] for a in view["artifacts"] if a["media_type"] == "image/png")
    assert warnings > 0 and pngs  # the fan map's non-monotone speed lines: the solver warns about them
    wait.until(lambda d: d.execute_script(
        "const imgs = [...document.querySelectorAll('.plots img')];"
        "return imgs.length > 0 && imgs.every(i => i.complete && i.naturalWidth > 0);"))
    shown = driver.execute_script("return [...document.querySelectorAll('.plots img')].map(i => i.alt).sort();")
    assert shown == pngs
    badge, items = driver.execute_script(
        "return [document.querySelector('.headline .warn').textContent, document.querySelectorAll('#warnings li').length];")
    assert f"{warnings} warnings" in badge and items == warnings

    # the list: the job with its warning count, links to its page; a filter narrows it
    driver.get(f"{base}/dashboard")
    rows = _rows(driver)  # read at once: the script may swap the rows in again at any time
    assert rows[job_id]["status"] == "succeeded" and rows[job_id]["warnings"].endswith(f"{warnings} warnings")
    assert rows[job_id]["href"].endswith(f"/dashboard/jobs/{job_id}")
    assert other["id"] in rows and rows[other["id"]]["warnings"] == ""
    Select(driver.find_element(By.NAME, "kind")).select_by_value("perfmap")
    driver.find_element(By.CSS_SELECTOR, "form.filters button").click()
    wait.until(lambda d: "kind=perfmap" in d.current_url)
    assert list(_rows(driver)) == [job_id]

    # live: a job submitted elsewhere appears in the open, unfiltered list without a reload
    driver.get(f"{base}/dashboard")
    driver.execute_script("window.sameDocument = true;")
    new = api.post("/v1/test-compute/jobs", json={"values": [3.0]}).json()
    wait.until(lambda d: d.find_elements(By.CSS_SELECTOR, f'tr[data-job="{new["id"]}"][data-status="succeeded"]'))
    assert driver.execute_script("return window.sameDocument === true;")
    expected = "events" if _has_route(app, "/v1/jobs/events") else "polling"
    assert driver.find_element(By.TAG_NAME, "body").get_attribute("data-transport") == expected


def test_upload_options_are_a_form_generated_from_the_schema(site, tmp_path):
    """The tube upload form: a field per option of its schema, starting at the defaults; a change in a field
    rewrites the JSON the form posts; an upload sends what differs from the defaults."""
    from selenium.webdriver.common.by import By
    from selenium.webdriver.support.ui import Select, WebDriverWait

    app, base, driver = site
    wait = WebDriverWait(driver, 20, poll_frequency=0.1)
    _login(driver, base)
    wait.until(lambda d: d.current_url.rstrip("/").endswith("/dashboard"))
    driver.get(f"{base}/dashboard/submit/tube")
    fields = driver.find_elements(By.CSS_SELECTOR, "#option-fields [data-option]")
    options_model = KINDS["tube"].request_model.model_fields["options"].annotation
    assert {f.get_attribute("data-option") for f in fields} == set(options_model.model_fields)
    by_name = {f.get_attribute("data-option"): f for f in fields}
    assert by_name["damping"].get_attribute("type") == "number" and by_name["damping"].get_attribute("value") == "1"
    assert by_name["common_bend_radius"].get_attribute("type") == "checkbox"
    assert by_name["bend_radius_model"].tag_name == "select"
    text = driver.find_element(By.ID, "options-json")
    by_name["damping"].clear()
    by_name["damping"].send_keys("0.5")
    Select(by_name["bend_radius_model"]).select_by_index(len(Select(by_name["bend_radius_model"]).options) - 1)
    by_name["common_bend_radius"].click()
    shown = json.loads(text.get_attribute("value"))
    assert shown["damping"] == 0.5 and shown["common_bend_radius"] is True
    assert shown["bend_radius_model"] == json.loads(Select(by_name["bend_radius_model"]).first_selected_option
                                                    .get_attribute("value"))

    # an upload through the generated form: the changed option is sent, the defaults are not
    values = tmp_path / "values.txt"
    values.write_text("1\n2\n3\n")
    driver.get(f"{base}/dashboard/submit/test-compute")
    seconds = driver.find_element(By.CSS_SELECTOR, '#option-fields [data-option="seconds"]')
    seconds.clear()
    seconds.send_keys("0.1")
    form = driver.find_element(By.ID, "upload-form")
    form.find_element(By.NAME, "file").send_keys(str(values))
    form.find_element(By.CSS_SELECTOR, "button[type=submit]").click()
    wait.until(lambda d: "/dashboard/jobs/" in d.current_url)
    job_id = re.search(r"/dashboard/jobs/([0-9a-f-]{36})", driver.current_url).group(1)
    api = httpx.Client(base_url=base, headers={"Authorization": f"Bearer {KEY}"}, timeout=10)
    assert api.get(f"/v1/jobs/{job_id}/input").json()["options"] == {"seconds": 0.1}


def _rows(driver) -> dict[str, dict[str, str]]:
    """The list's rows by job id: status, warning badge and link."""
    return driver.execute_script("""
        const rows = {};
        for (const row of document.querySelectorAll('tr[data-job]')) {
            const warn = row.querySelector('[data-field=warnings]');
            rows[row.dataset.job] = {status: row.querySelector('[data-field=status]').textContent,
                                     warnings: warn ? warn.textContent.trim() : '', href: row.querySelector('a').href};
        }
        return rows;""")


def _login(driver, base: str) -> None:
    from selenium.webdriver.common.by import By

    driver.get(f"{base}/dashboard/login")
    driver.find_element(By.NAME, "key").send_keys(KEY)
    driver.find_element(By.CSS_SELECTOR, "form.login button").click()


def test_pages_poll_when_the_browser_has_no_event_stream(site):
    """Without EventSource (or when the stream fails) the pages poll: a job's page every 2 s."""
    from selenium.common.exceptions import StaleElementReferenceException
    from selenium.webdriver.common.by import By
    from selenium.webdriver.support.ui import WebDriverWait

    app, base, driver = site
    wait = WebDriverWait(driver, 20, poll_frequency=0.1, ignored_exceptions=(StaleElementReferenceException,))
    driver.execute_cdp_cmd("Page.addScriptToEvaluateOnNewDocument", {"source": "delete window.EventSource;"})
    _login(driver, base)
    wait.until(lambda d: d.current_url.rstrip("/").endswith("/dashboard"))
    driver.get(f"{base}/dashboard/submit/test-compute")
    form = driver.find_element(By.ID, "json-form")
    body = form.find_element(By.NAME, "body")
    body.clear()
    body.send_keys('{"values": [-1.0, 2.0], "seconds": 1.5}')
    form.find_element(By.CSS_SELECTOR, "button[type=submit]").click()
    wait.until(lambda d: "/dashboard/jobs/" in d.current_url)
    driver.execute_script("window.sameDocument = true;")
    wait.until(lambda d: d.find_element(By.CSS_SELECTOR, "#job-detail [data-field=status]").text == "succeeded")
    assert driver.execute_script("return window.sameDocument === true;")
    assert driver.find_element(By.TAG_NAME, "body").get_attribute("data-transport") == "polling"
    assert "1 warning" in driver.find_element(By.CSS_SELECTOR, ".headline .warn").text


UPLOADS = {"alignment": "alignment/ladder.pcf", "tube": "tube/scan.xyz", "perfmap": "perfmap/n3_fan_map.csv",
           "dedup": "dedup/tunnel_3rings.ifc", "flowmeter": "flowmeter/meter.json",
           "polyhedra": "polyhedra/two_offices.idf", "rigidity": "rigidity/hinged_wall.ldr"}
ERRORS = "window.pageErrors = []; window.addEventListener('error', e => window.pageErrors.push(String(e.message)));"


@pytest.mark.parametrize("kind", sorted(UPLOADS))
def test_every_kinds_generated_option_form_writes_back_what_it_shows_and_submits(site, kind):
    """Each kind's upload form, generated from its options schema: a field per option, each writing back exactly
    the value it shows when touched (no number made a string, no text's lines lost, no choice changed), no script
    error; the upload of the kind's example file through it is accepted."""
    from selenium.webdriver.common.by import By
    from selenium.webdriver.support.ui import WebDriverWait

    app, base, driver = site
    assert set(UPLOADS) == {k for k, spec in KINDS.items() if spec.upload_extensions}  # every kind that reads files
    wait = WebDriverWait(driver, 30, poll_frequency=0.1)
    driver.execute_cdp_cmd("Page.addScriptToEvaluateOnNewDocument", {"source": ERRORS})
    _login(driver, base)
    wait.until(lambda d: d.current_url.rstrip("/").endswith("/dashboard"))
    driver.get(f"{base}/dashboard/submit/{kind}")
    schema = json.loads(driver.find_element(By.ID, "options-schema").get_attribute("textContent"))
    fields = driver.find_elements(By.CSS_SELECTOR, "#option-fields [data-option]")
    assert sorted(f.get_attribute("data-option") for f in fields) == sorted(schema["properties"])
    text = driver.find_element(By.ID, "options-json")
    before = json.loads(text.get_attribute("value"))
    driver.execute_script("document.querySelectorAll('#option-fields [data-option]')"
                          ".forEach(i => i.dispatchEvent(new Event('change')));")
    assert json.loads(text.get_attribute("value")) == before
    form = driver.find_element(By.ID, "upload-form")
    form.find_element(By.NAME, "file").send_keys(str(REPO / "examples" / UPLOADS[kind]))
    form.find_element(By.CSS_SELECTOR, "button[type=submit]").click()
    wait.until(lambda d: "/dashboard/jobs/" in d.current_url or d.find_elements(By.ID, "problem"))
    problem = driver.find_elements(By.ID, "problem")
    assert not problem, problem[0].text
    assert driver.execute_script("return window.pageErrors;") == []
    job_id = re.search(r"/dashboard/jobs/([0-9a-f-]{36})", driver.current_url).group(1)
    httpx.post(f"{base}/v1/jobs/{job_id}/cancel", headers={"Authorization": f"Bearer {KEY}"})  # not needed further


def test_a_tube_nominal_is_typed_in_lines_or_read_from_a_file(site):
    """The nominal CSV was a one-line text field that dropped its line breaks (422 'holds no rows'): now a
    multi-line field, filled from a chosen file; the upload then carries the CSV whole."""
    from selenium.webdriver.common.by import By
    from selenium.webdriver.support.ui import WebDriverWait

    app, base, driver = site
    wait = WebDriverWait(driver, 30, poll_frequency=0.1)
    _login(driver, base)
    wait.until(lambda d: d.current_url.rstrip("/").endswith("/dashboard"))
    driver.get(f"{base}/dashboard/submit/tube")
    nominal = driver.find_element(By.CSS_SELECTOR, '#option-fields [data-option="nominal_csv"]')
    assert nominal.tag_name == "textarea"
    nominal.send_keys("1,80,0,90,18\n2,45,90,45,18")
    assert json.loads(driver.find_element(By.ID, "options-json").get_attribute("value"))["nominal_csv"] == \
        "1,80,0,90,18\n2,45,90,45,18"
    csv = REPO / "examples" / "tube" / "nominal_lra.csv"
    driver.find_element(By.CSS_SELECTOR, 'input[type=file][data-file-for="nominal_csv"]').send_keys(str(csv))
    wait.until(lambda d: d.find_element(By.CSS_SELECTOR, '[data-option="nominal_csv"]').get_attribute("value")
               == csv.read_text())
    shown = json.loads(driver.find_element(By.ID, "options-json").get_attribute("value"))
    assert shown["nominal_csv"] == csv.read_text()
    form = driver.find_element(By.ID, "upload-form")
    form.find_element(By.NAME, "file").send_keys(str(REPO / "examples" / "tube" / "scan.xyz"))
    form.find_element(By.CSS_SELECTOR, "button[type=submit]").click()
    wait.until(lambda d: "/dashboard/jobs/" in d.current_url or d.find_elements(By.ID, "problem"))
    assert not driver.find_elements(By.ID, "problem"), driver.find_element(By.ID, "problem").text
    job_id = re.search(r"/dashboard/jobs/([0-9a-f-]{36})", driver.current_url).group(1)
    api = httpx.Client(base_url=base, headers={"Authorization": f"Bearer {KEY}"}, timeout=10)
    assert api.get(f"/v1/jobs/{job_id}/input").json()["options"]["nominal_csv"] == csv.read_text()
    api.post(f"/v1/jobs/{job_id}/cancel")


def test_a_plot_opens_full_size_and_the_first_warning_heads_the_page(site):
    from selenium.webdriver.common.by import By
    from selenium.common.exceptions import StaleElementReferenceException
    from selenium.webdriver.common.keys import Keys
    from selenium.webdriver.support.ui import WebDriverWait

    app, base, driver = site
    wait = WebDriverWait(driver, 120, poll_frequency=0.2, ignored_exceptions=(StaleElementReferenceException,))
    api = httpx.Client(base_url=base, headers={"Authorization": f"Bearer {KEY}"}, timeout=10)
    job = api.post("/v1/polyhedra/jobs", json=KINDS["polyhedra"].example()).json()
    warned = api.post("/v1/test-compute/jobs", json={"values": [-1.0]}).json()
    _login(driver, base)
    wait.until(lambda d: d.current_url.rstrip("/").endswith("/dashboard"))
    driver.get(f"{base}/dashboard/jobs/{job['id']}")
    wait.until(lambda d: d.find_element(By.CSS_SELECTOR, "#job-detail [data-field=status]").text == "succeeded")
    wait.until(lambda d: d.execute_script(
        "const i = document.querySelector('.plots img'); return i && i.complete && i.naturalWidth > 0;"))
    inline, page = driver.execute_script(
        "return [document.querySelector('.plots img').getBoundingClientRect().width,"
        " document.querySelector('main').getBoundingClientRect().width];")
    assert inline > 0.85 * page - 64  # the page's width (less its padding), not half of it
    driver.find_element(By.CSS_SELECTOR, ".plots a.plot-open").click()
    wait.until(lambda d: d.execute_script(
        "const v = document.getElementById('plot-viewer'); const i = v && v.querySelector('img');"
        "return v && v.open && i.complete && i.naturalWidth > 0;"))
    natural, shown = driver.execute_script(
        "const i = document.querySelector('#plot-viewer img'); return [i.naturalWidth, i.getBoundingClientRect().width];")
    assert abs(shown - natural) <= 1  # its own resolution, scrolled in the viewer
    assert "/dashboard/jobs/" in driver.current_url  # no navigation (the artifact link would download)
    driver.find_element(By.TAG_NAME, "body").send_keys(Keys.ESCAPE)
    wait.until(lambda d: not d.execute_script("return document.getElementById('plot-viewer').open;"))

    driver.get(f"{base}/dashboard/jobs/{warned['id']}")
    wait.until(lambda d: d.find_elements(By.ID, "report-banner"))
    banner = driver.find_element(By.ID, "report-banner")
    assert banner.text.startswith("⚠ negative Some values are negative.") and banner.is_displayed()
    assert banner.location["y"] < driver.find_element(By.CSS_SELECTOR, ".facts").location["y"]
    driver.get(f"{base}/dashboard")
    # the live list swaps a row in when its job changes: read it afresh until it shows the finished job
    first_warning = f'tr[data-job="{warned["id"]}"] [data-field=first-warning]'
    wait.until(lambda d: d.find_element(By.CSS_SELECTOR, first_warning).text == "negative")


@pytest.fixture
def inspecting_site(tmp_path, chromium_driver):
    plugins = ["tests.support.kinds", "tests.app.test_dashboard_glance"]  # test-inspect: a failed inspection
    app = create_app(service_settings(tmp_path, api_keys=[f"alice:{KEY}"], plugins=plugins))
    with browser.page_on(app, chromium_driver) as (base, driver):
        yield app, base, driver


def test_a_failed_inspection_that_finishes_on_an_open_list_shows_its_verdict(inspecting_site):
    """The live list swaps in the finished row with its red FAIL beside 'succeeded'; its page heads with the
    verdict's banner, not a yellow warning."""
    from selenium.common.exceptions import StaleElementReferenceException
    from selenium.webdriver.common.by import By
    from selenium.webdriver.support.ui import WebDriverWait

    app, base, driver = inspecting_site
    wait = WebDriverWait(driver, 60, poll_frequency=0.2, ignored_exceptions=(StaleElementReferenceException,))
    api = httpx.Client(base_url=base, headers={"Authorization": f"Bearer {KEY}"}, timeout=10)
    _login(driver, base)
    wait.until(lambda d: d.current_url.rstrip("/").endswith("/dashboard"))
    job = api.post("/v1/test-inspect/jobs", json={}).json()  # after the list was shown: it arrives live
    verdict = f'tr[data-job="{job["id"]}"] [data-field=verdict]'
    wait.until(lambda d: d.find_elements(By.CSS_SELECTOR, verdict) and
               d.find_element(By.CSS_SELECTOR, verdict).text == "✗ FAIL")
    status = driver.find_element(By.CSS_SELECTOR, f'tr[data-job="{job["id"]}"] [data-field=status]').text
    assert status == "succeeded"
    colour = driver.find_element(By.CSS_SELECTOR, verdict).value_of_css_property("background-color")
    assert colour == "rgba(176, 0, 32, 1)"  # the failed status's red
    driver.get(f"{base}/dashboard/jobs/{job['id']}")
    banner = wait.until(lambda d: d.find_element(By.ID, "report-banner"))
    assert banner.text.startswith("Verdict: FAIL — the job ran to the end, but its result does not pass: "
                                  "inspection_failed") and "verdict" in banner.get_attribute("class")


def test_each_test_has_a_tab_as_fresh_as_a_new_browsers(site, tmp_path):
    """The browser tests of a test process share one Chromium: what a test left in it (a script injected into each new document,
    a cookie for the host, whatever the port) does not reach the next test's page."""
    app, base, driver = site
    driver.get(f"{base}/healthz")
    driver.execute_cdp_cmd("Page.addScriptToEvaluateOnNewDocument", {"source": "window.leftOver = true;"})
    driver.add_cookie({"name": "left_over", "value": "1"})
    driver.get(f"{base}/healthz")
    assert driver.execute_script("return window.leftOver === true;") and driver.get_cookie("left_over")
    with browser.page_on(create_app(service_settings(tmp_path / "next")), driver) as (later, _):
        driver.get(f"{later}/healthz")
        assert driver.execute_script("return window.leftOver === undefined;")
        assert driver.get_cookie("left_over") is None and len(driver.window_handles) == 1
