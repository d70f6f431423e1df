"""A report's warnings at a glance: the list row names the first warning's code (a kind puts its gravest first,
e.g. tube's ``inspection_failed``), the job's page opens with a banner of it (a failure's banner names its stage),
plots are links that open full size, and a file-text option (tube's ``nominal_csv``) is offered as one.

The module is also a plugin (``SPECS``): a kind whose report carries an inspection-like warning first."""

from __future__ import annotations

import html
import re

import pytest
from fastapi.testclient import TestClient
from pydantic import BaseModel

from plantsolve.app.dashboard_views import options_schema
from plantsolve.app.main import create_app
from plantsolve.schemas.common import Report, StrictModel
from plantsolve.solvers.base import Solved, SolverSpec
from plantsolve.solvers.kinds import KINDS
from tests.conftest import service_settings, wait_for

WARNINGS = [
    {"code": "inspection_failed", "message": "The bend at 120 mm is out of tolerance: angle 91.2° (tolerance ±0.5°)."},
    {"code": "sparse_scan", "message": "Few points on straight 3."},
    {"code": "spring_back", "message": "Spring-back estimated from one bend."},
]


class InspectRequest(StrictModel):
    warn: bool = True


class InspectResult(BaseModel):
    report: Report


def solve_inspect(request: InspectRequest, progress) -> Solved:
    warnings = WARNINGS if request.warn else []
    return Solved(InspectResult(report=Report(status="warning" if warnings else "ok", message="inspected",
                                              warnings=warnings)))


SPECS = (SolverSpec("test-inspect", InspectRequest, InspectResult, solve_inspect, "test-1"),)


@pytest.fixture
def client(tmp_path):
    settings = service_settings(tmp_path, plugins=["tests.support.kinds", "tests.app.test_dashboard_glance"])
    with TestClient(create_app(settings)) as client:
        yield client


def _row(page: str, job_id: str) -> str:
    return re.search(rf'<tr data-job="{job_id}".*?</tr>', page, re.S).group(0)


def test_the_first_warning_is_on_the_list_row_and_atop_the_page(client):
    warned = wait_for(client, client.post("/v1/test-inspect/jobs", json={}).json()["id"])
    clean = wait_for(client, client.post("/v1/test-inspect/jobs", json={"warn": False}).json()["id"])
    page = client.get("/dashboard").text
    row = _row(page, warned["id"])
    first = re.search(r'<span class="first-warning" data-field="first-warning" title="([^"]*)">([^<]*)</span>', row)
    assert first.group(2) == "inspection_failed" and html.unescape(first.group(1)) == WARNINGS[0]["message"]
    assert "3 warnings" in row
    assert "first-warning" not in _row(page, clean["id"])

    detail = client.get(f"/dashboard/jobs/{warned['id']}").text
    banner = re.search(r'<div class="banner verdict" role="alert" id="report-banner">(.*?)</div>', detail,
                       re.S).group(1)
    assert "<code>inspection_failed</code>" in banner and html.unescape(banner).count(WARNINGS[0]["message"]) == 1
    assert "2 other warnings" in banner and 'href="#warnings"' in banner
    # at the top: before the facts, the report and the plots
    assert detail.index('id="report-banner"') < detail.index('class="facts"') < detail.index('id="warnings"')
    assert 'id="report-banner"' not in client.get(f"/dashboard/jobs/{clean['id']}").text


def test_a_failed_verdict_is_shown_beside_succeeded_not_as_a_warning_alone(client):
    """A failed inspection is a job that succeeded with a result that does not pass: the list and the page say
    FAIL in red beside the green 'succeeded'; a warning that is only a caveat keeps the yellow banner."""
    failed = wait_for(client, client.post("/v1/test-inspect/jobs", json={}).json()["id"])
    caveat = wait_for(client, client.post("/v1/test-compute/jobs", json={"values": [-1.0]}).json()["id"])
    page = client.get("/dashboard").text
    row = _row(page, failed["id"])
    assert 'class="status-succeeded has-verdict"' in row
    assert re.search(r'<span class="badge verdict" data-field="verdict" title="([^"]*)">&#10007; FAIL</span>', row)
    assert "has-warnings" in _row(page, caveat["id"]) and 'data-field="verdict"' not in _row(page, caveat["id"])

    detail = client.get(f"/dashboard/jobs/{failed['id']}").text
    headline = re.search(r'<p class="headline">(.*?)</p>', detail, re.S).group(1)
    assert headline.index(">succeeded<") < headline.index("&#10007; FAIL</a>")
    banner = re.search(r'<div class="banner verdict" role="alert" id="report-banner">(.*?)</div>', detail,
                       re.S).group(1)
    assert banner.startswith("<b>Verdict: FAIL</b> &mdash; the job ran to\n  the end, but its result does not pass")
    other = client.get(f"/dashboard/jobs/{caveat['id']}").text
    assert '<div class="banner warn" role="alert" id="report-banner">' in other and 'data-field="verdict"' not in other


def test_a_failed_jobs_page_opens_with_its_stage_and_message(client):
    failed = wait_for(client, client.post("/v1/test-fail/jobs", json={"message": "the fit diverged"}).json()["id"])
    detail = client.get(f"/dashboard/jobs/{failed['id']}").text
    banner = re.search(r'<div class="banner failed" role="alert" id="report-banner">(.*?)</div>', detail, re.S).group(1)
    assert banner == "<b>Failed</b> at stage <code>fit</code>: the fit diverged"
    assert _row(client.get("/dashboard").text, failed["id"]).count("first-warning") == 0


def test_plots_are_links_that_open_full_size(client):
    job = wait_for(client, client.post("/v1/polyhedra/jobs", json=KINDS["polyhedra"].example()).json()["id"], timeout=120)
    page = client.get(f"/dashboard/jobs/{job['id']}").text
    pngs = [a for a in job["artifacts"] if a["media_type"] == "image/png"]
    assert pngs
    for artifact in pngs:
        url = f"/v1/jobs/{job['id']}/artifacts/{artifact['name']}"
        assert f'<a class="plot-open" href="{url}" data-name="{artifact["name"]}"' in page
    css = client.get("/dashboard-static/dashboard.css").text
    assert re.search(r"\.plots img \{[^}]*width: 100%", css) and "max-width: 860px" not in css


def test_a_file_text_option_is_declared_long_enough_for_the_form_to_offer_a_file(client):
    """The form generator (dashboard.js) makes a multi-line field with a file picker of a string option longer
    than LONG_TEXT characters; tube's nominal CSV is one, a perfmap sheet name is not."""
    assert "var LONG_TEXT = 1000;" in client.get("/dashboard-static/dashboard.js").text
    nominal = options_schema(KINDS["tube"])["properties"]["nominal_csv"]
    assert max(option.get("maxLength", 0) for option in nominal["anyOf"]) > 1000
    sheet = options_schema(KINDS["perfmap"])["properties"]["sheet"]
    assert max(option.get("maxLength", 0) for option in sheet["anyOf"]) <= 1000
