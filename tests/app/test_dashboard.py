"""The dashboard's pages through the ASGI test client: list filters and paging, a job's page with
its warnings, plots, downloads and input, the submit forms and their errors, and who may see and post."""

from __future__ import annotations

import html
import json
import re
import uuid

import pytest
from fastapi.testclient import TestClient

from plantsolve.app.auth import form_token
from plantsolve.app.dashboard_views import progress_text, result_summary
from plantsolve.app.main import create_app
from plantsolve.solvers.kinds import KINDS
from tests.conftest import service_settings, wait_for
from tests.support.login import log_in


def _submit(client, values, headers=None) -> dict:
    job = client.post("/v1/test-compute/jobs", json={"values": values}, headers=headers or {}).json()
    return wait_for(client, job["id"], headers=headers)


def _row_ids(html: str) -> list[str]:
    return re.findall(r'<tr data-job="([0-9a-f-]{36})"', html)


def test_list_filters_by_kind_status_and_text(client):
    clean = _submit(client, [1.0])
    warned = _submit(client, [-1.0])
    failed = client.post("/v1/test-fail/jobs", json={"message": "the 100% fit broke"}).json()
    wait_for(client, failed["id"])

    everything = client.get("/dashboard").text
    assert _row_ids(everything) == [failed["id"], warned["id"], clean["id"]]  # newest first
    assert _row_ids(client.get("/dashboard?kind=test-compute").text) == [warned["id"], clean["id"]]
    assert _row_ids(client.get("/dashboard?status=failed").text) == [failed["id"]]
    assert _row_ids(client.get("/dashboard?kind=test-compute&status=failed").text) == []
    # text: part of the id (with its dashes), the kind, the report's message; LIKE's % is taken literally
    assert _row_ids(client.get(f"/dashboard?q={clean['id'][4:13]}").text) == [clean["id"]]
    assert _row_ids(client.get("/dashboard?q=FAIL").text) == [failed["id"]]
    assert _row_ids(client.get("/dashboard", params={"q": "100% fit"}).text) == [failed["id"]]
    assert _row_ids(client.get("/dashboard", params={"q": "1%0"}).text) == []
    assert _row_ids(client.get("/dashboard?q=negative").text) == [warned["id"]]  # a warning's code
    page = client.get("/dashboard?q=nothing-like-this").text
    assert "No jobs match these filters." in page
    # the filter form shows what is applied; the page follows the events of the same kind and status
    assert '<option value="failed" selected>' in client.get("/dashboard?status=failed").text
    assert 'data-events="/v1/jobs/events?status=failed"' in client.get("/dashboard?status=failed&q=x").text
    assert 'data-events="/v1/jobs/events"' in everything


def test_list_pages_with_the_repository_cursor(client):
    ids = [_submit(client, [float(i)])["id"] for i in range(5)]
    seen, url = [], "/dashboard?limit=2"
    for _ in range(5):
        page = client.get(url).text
        seen.append(_row_ids(page))
        older = re.search(r'<a rel="next" href="([^"]+)"', page)
        if older is None:
            break
        url = older.group(1).replace("&amp;", "&")
        assert "limit=2" in url
    assert seen == [ids[4:2:-1], ids[2:0:-1], ids[:1]]
    assert "Newest" in client.get(url).text  # a later page links back to the first
    assert client.get("/dashboard?cursor=not-a-cursor").status_code == 422


def test_a_warning_is_visible_in_the_list_and_on_the_page(client):
    clean = _submit(client, [1.0])
    warned = _submit(client, [-1.0, 2.0])
    page = client.get("/dashboard").text
    rows = {m.group(1): m.group(0) for m in re.finditer(r'<tr data-job="([^"]+)".*?</tr>', page, re.S)}
    assert "has-warnings" in rows[warned["id"]] and "1 warning<" in rows[warned["id"]]
    assert "has-warnings" not in rows[clean["id"]] and "warning" not in rows[clean["id"]]
    assert f'href="/dashboard/jobs/{warned["id"]}"' in rows[warned["id"]]  # the job's page, not raw JSON
    detail = client.get(f"/dashboard/jobs/{warned['id']}").text
    assert 'id="warnings"' in detail and "<code>negative</code> Some values are negative." in detail
    assert 'class="badge big warn"' in detail
    assert 'id="warnings"' not in client.get(f"/dashboard/jobs/{clean['id']}").text


def test_a_job_page_shows_plots_downloads_input_and_result(client):
    example = KINDS["polyhedra"].example()
    job = client.post("/v1/polyhedra/jobs", json=example).json()
    view = wait_for(client, job["id"])
    assert view["status"] == "succeeded"
    page = client.get(f"/dashboard/jobs/{job['id']}").text
    base = f"/v1/jobs/{job['id']}"
    for artifact in view["artifacts"]:
        assert f'href="{base}/artifacts/{artifact["name"]}" download' in page
    pngs = [a["name"] for a in view["artifacts"] if a["media_type"] == "image/png"]
    assert pngs and all(f'<img src="{base}/artifacts/{name}"' in page for name in pngs)
    assert client.get(f"{base}/artifacts/{pngs[0]}").content[:8] == b"\x89PNG\r\n\x1a\n"
    assert f'href="{base}/result"' in page and 'class="summary-table"' in page
    assert "&#34;faces&#34;" in page or "&quot;faces&quot;" in page  # the JSON input, escaped into a <pre>
    assert ">done<" in page and "Cancel job" not in page
    fragment = client.get(f"/dashboard/jobs/{job['id']}/detail").text
    assert fragment.lstrip().startswith('<section class="job" data-status="succeeded">')


def test_a_failed_job_page_shows_stage_and_message(client):
    job = client.post("/v1/test-fail/jobs", json={"message": "cannot fit"}).json()
    wait_for(client, job["id"])
    page = client.get(f"/dashboard/jobs/{job['id']}").text
    assert "stage <code>fit</code>: cannot fit" in page and "report-failed" in page
    assert "Full result" not in page


def test_unknown_job_and_kind_are_404_pages(client):
    for path in ("/dashboard/jobs/00000000-0000-4000-8000-000000000000",
                 "/dashboard/jobs/00000000-0000-4000-8000-000000000000/detail", "/dashboard/submit/pipes"):
        response = client.get(path)
        assert response.status_code == 404 and response.headers["content-type"].startswith("text/html"), path
        assert "Not found" in response.text
    assert "Known kinds: " in client.get("/dashboard/submit/pipes").text
    assert client.get("/dashboard/jobs/not-a-uuid").status_code == 422


def test_the_submit_form_is_prefilled_and_posts_through_the_service(client):
    page = client.get("/dashboard/submit/perfmap").text
    assert 'name="file" accept=".csv,.xlsx,.json,.py,.map"' in page
    assert "&#34;cubic&#34;" in page or "&quot;cubic&quot;" in page  # the example, in the JSON form
    response = client.post("/dashboard/submit/test-compute", data={"source": "json", "body": '{"values": [4.0, 5.0]}'},
                           follow_redirects=False)
    assert response.status_code == 303
    job_id = response.headers["location"].rsplit("/", 1)[-1]
    assert wait_for(client, job_id)["status"] == "succeeded"
    assert client.get(f"/v1/jobs/{job_id}/result").json()["total"] == 9.0

    upload = client.post("/dashboard/submit/test-compute", data={"source": "upload", "options": '{"seconds": 0}'},
                         files={"file": ("values.txt", b"1\n2\n3\n", "text/plain")}, follow_redirects=False)
    assert upload.status_code == 303
    job_id = upload.headers["location"].rsplit("/", 1)[-1]
    assert wait_for(client, job_id)["status"] == "succeeded"
    assert client.get(f"/v1/jobs/{job_id}/result").json()["total"] == 6.0
    page = client.get(f"/dashboard/jobs/{job_id}").text
    assert f'href="/v1/jobs/{job_id}/input/file" download><code>values.txt</code>' in page and "&#34;seconds&#34;" in page
    assert client.get(f"/v1/jobs/{job_id}/input/file").content == b"1\n2\n3\n"


@pytest.mark.parametrize("data, files, status, shown", [
    ({"source": "json", "body": '{"values": [666]}'}, None, 422, "<code>/values/0</code> must not be 666"),
    ({"source": "json", "body": '{"values": "x"}'}, None, 422, "<code>/values</code>"),
    ({"source": "json", "body": "{not json"}, None, 422, "Invalid input"),
    ({"source": "upload", "options": "[1]"}, {"file": ("v.txt", b"1\n")}, 422, "<code>/options</code> must be a JSON object"),
    ({"source": "upload", "options": ""}, {"file": ("", b"")}, 422, "<code>/file</code> no file chosen"),
    ({"source": "upload", "options": ""}, {"file": ("v.csv", b"1\n")}, 415, "not accepted by"),
])
def test_form_errors_are_shown_on_the_form(client, data, files, status, shown):
    response = client.post("/dashboard/submit/test-compute", data=data, files=files or {"unused": ("", b"")})
    assert response.status_code == status and response.headers["content-type"].startswith("text/html")
    assert 'id="problem"' in response.text and shown in response.text
    if data["source"] == "json":  # what was typed stays in the form
        assert data["body"].replace('"', "&#34;") in response.text
    assert client.get("/v1/jobs").json()["items"] == []


def test_progress_shows_the_status_not_a_share_of_a_finished_solver():
    assert progress_text("running", 1.0) == "storing result"
    assert progress_text("running", 0.87) == "87%"
    assert progress_text("queued", 0.0) == "waiting"
    assert progress_text("succeeded", 1.0) == "done"
    assert progress_text("failed", 0.3) == "failed"


def test_result_summary_lists_scalars_and_sizes():
    rows = {name: value for name, value, _ in result_summary(
        {"total": 1.23456789, "points": [[0, 0]] * 7, "range": [1.0, 2.5], "note": None,
         "fit": {"rms": 0.5, "method": "ls"}, "report": {"status": "ok"}})}
    assert rows == {"total": "1.23457", "points": "list of 7", "range": "[1, 2.5]", "note": "—",
                    "fit.rms": "0.5", "fit.method": "ls"}


@pytest.mark.parametrize("kind, result, expected", [
    # the unit a field states, its placeholder filled from the result's own units fields; counts have none
    ("tube", {"pipe_radius": 6.0, "start": [1.0, 2.0, 3.0], "units": "in", "residuals": {"count": 5, "rms": 0.1},
              "orientation": [1.0, 0.0, 0.0, 0.0]},
     {"pipe_radius": "in", "start": "in", "units": "", "residuals.count": "", "residuals.rms": "in",
      "orientation": "1"}),
    ("perfmap", {"units": {"flow": "kg/s", "pressure": "1", "efficiency": "1"}, "flow_range": [1.0, 2.0]},
     {"units.flow": "", "units.pressure": "", "units.efficiency": "", "flow_range": "kg/s"}),
    ("flowmeter", {"signal": 0.002, "units": "mm", "grid_units": ["mm", "mm", "1"], "grid": [[0.0, 0.0, 1.0]]},
     {"signal": "V", "units": "", "grid_units": "", "grid": "per column: mm, mm, 1"}),
    ("dedup", {"timings": {"parse": 0.01}, "products_total": 3, "tolerance": 1e-5, "units": "m"},
     {"timings.parse": "s", "products_total": "", "tolerance": "m", "units": ""}),
])
def test_result_summary_gives_each_number_its_unit(kind, result, expected):
    assert {name: unit for name, _, unit in result_summary(result, KINDS[kind].result_model)} == expected


def test_a_job_page_shows_the_units_of_its_result(client):
    assert result_summary({"norm": 5.0}, KINDS["polyhedra"].result_model) == [("norm", "5", "")]  # none made up
    request = {**KINDS["polyhedra"].example(), "units": "cm"}
    job = wait_for(client, client.post("/v1/polyhedra/jobs", json=request).json()["id"])
    assert job["status"] == "succeeded", job
    page = client.get(f"/dashboard/jobs/{job['id']}").text
    assert "<thead><tr><th>field</th><th>value</th><th>unit</th></tr></thead>" in page
    assert re.search(r'<tr><th>total_volume</th><td>[0-9.e+]+</td><td class="unit">cm\^3</td></tr>', page)


@pytest.fixture
def keyed(tmp_path):
    with TestClient(create_app(service_settings(tmp_path, api_keys=["alice:key-a", "bob:key-b"],
                                                      webhook_private_targets=True))) as client:
        yield client


def test_pages_need_a_key_and_show_only_the_callers_jobs(keyed):
    alice, bob = {"Authorization": "Bearer key-a"}, {"Authorization": "Bearer key-b"}
    job = _submit(keyed, [1.0], headers=alice)
    page = f"/dashboard/jobs/{job['id']}"
    for path in (page, f"{page}/detail", "/dashboard/rows", "/dashboard/submit/test-compute"):
        assert keyed.get(path).status_code == 401, path
        assert keyed.get(path, headers={"Authorization": "Bearer wrong"}).status_code == 401, path
    assert keyed.get(page, headers=alice).status_code == 200
    assert keyed.get(page, headers=bob).status_code == 404  # another tenant's job does not exist for bob
    assert job["id"] not in keyed.get("/dashboard", headers=bob).text
    assert keyed.get("/dashboard-static/dashboard.css").status_code == 200  # the login page's style needs no key
    assert keyed.post("/dashboard/submit/test-compute", data={"source": "json", "body": '{"values": [1]}'},
                      files={"unused": ("", b"")}).status_code == 401


def test_a_cookie_posts_dashboard_forms_only_with_their_token(keyed):
    log_in(keyed, "key-a")
    form = keyed.get("/dashboard/submit/test-compute").text
    token = re.search(r'name="token" value="([0-9a-f]*)"', form).group(1)
    assert token == form_token(keyed.cookies["plantsolve_session"])  # derived from the session, not the key
    body = {"source": "json", "body": '{"values": [2.0]}'}
    no_file = {"unused": ("", b"")}
    assert keyed.post("/dashboard/submit/test-compute", data=body, files=no_file).status_code == 403
    wrong = keyed.post("/dashboard/submit/test-compute", data={**body, "token": form_token("key-b")}, files=no_file)
    assert wrong.status_code == 403 and "token" in wrong.text
    cross = keyed.post("/dashboard/submit/test-compute", data={**body, "token": token}, files=no_file,
                       headers={"Sec-Fetch-Site": "cross-site"})
    assert cross.status_code == 403
    assert keyed.get("/v1/jobs", headers={"Authorization": "Bearer key-a"}).json()["items"] == []
    sent = keyed.post("/dashboard/submit/test-compute", data={**body, "token": token}, files=no_file,
                      follow_redirects=False)
    assert sent.status_code == 303
    job_id = sent.headers["location"].rsplit("/", 1)[-1]
    # the job belongs to the cookie's tenant
    assert wait_for(keyed, job_id, headers={"Authorization": "Bearer key-a"})["status"] == "succeeded"
    assert keyed.get(f"/v1/jobs/{job_id}", headers={"Authorization": "Bearer key-b"}).status_code == 404
    # the cookie still writes nothing under /v1
    assert keyed.post("/v1/test-compute/jobs", json={"values": [1.0]}).status_code == 401


def test_a_running_job_can_be_cancelled_from_its_page(keyed):
    alice = {"Authorization": "Bearer key-a"}
    job = keyed.post("/v1/test-compute/jobs", json={"values": [1.0], "seconds": 20}, headers=alice).json()
    wait_for(keyed, job["id"], statuses=("running",), headers=alice)
    log_in(keyed, "key-a")
    page = keyed.get(f"/dashboard/jobs/{job['id']}").text
    assert "Cancel job" in page and 'data-status="running"' in page
    token = re.search(r'name="token" value="([0-9a-f]+)"', page).group(1)
    assert keyed.post(f"/dashboard/jobs/{job['id']}/cancel", data={}).status_code == 403
    done = keyed.post(f"/dashboard/jobs/{job['id']}/cancel", data={"token": token})
    assert done.status_code == 200 and 'data-status="cancelled"' in done.text


def test_templates_and_static_files_are_package_data():
    """A non-editable install carries every file the pages need (pyproject's package-data globs)."""
    import fnmatch
    import tomllib

    from tests.conftest import REPO

    globs = tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["setuptools"]["package-data"]["plantsolve.app"]
    app = REPO / "plantsolve" / "app"
    files = [p.relative_to(app).as_posix() for folder in ("templates", "static") for p in (app / folder).rglob("*")
             if p.is_file()]
    assert "templates/job.html" in files and "static/dashboard.js" in files
    assert [f for f in files if not any(fnmatch.fnmatch(f, g) for g in globs)] == []


def test_a_running_job_whose_solver_is_through_is_not_shown_as_100_percent(tmp_path):
    """The runner sets 1.0 when the solver returns and only then stores the result: the list and the
    page say 'running' and 'storing result' for that moment, never 'running | 100 %'."""
    with TestClient(create_app(service_settings(tmp_path), run_jobs=False)) as client:
        job = client.post("/v1/test-compute/jobs", json={"values": [1.0]}).json()
        repo = client.app.state.ctx.repo
        attempt = repo.claim(uuid.UUID(job["id"]), lease_seconds=30, worker="test")
        assert repo.set_progress(uuid.UUID(job["id"]), attempt, 0.87, "step 18 of 20")
        row = re.search(r'<tr data-job="%s".*?</tr>' % job["id"], client.get("/dashboard").text, re.S).group(0)
        assert ">running<" in row and ">87%<" in row and "step 18 of 20" in row
        assert repo.set_progress(uuid.UUID(job["id"]), attempt, 1.0, "done")
        row = re.search(r'<tr data-job="%s".*?</tr>' % job["id"], client.get("/dashboard").text, re.S).group(0)
        assert ">running<" in row and ">storing result<" in row and "100%" not in row
        page = client.get(f"/dashboard/jobs/{job['id']}").text
        assert 'data-status="running"' in page and ">storing result<" in page and "Cancel job" in page


def test_pretty_json_reads_back_and_keeps_number_lists_on_one_line():
    from plantsolve.app.dashboard_views import pretty

    for kind, spec in KINDS.items():
        example = spec.example()
        assert json.loads(pretty(example)) == example, kind
    text = pretty({"points": [[0.0, 1.5, -2.0], [1, 2, 3]], "name": "a\"b", "empty": {}, "none": []})
    assert '[0.0, 1.5, -2.0]' in text and '"name": "a\\"b"' in text and '"empty": {}' in text
    assert json.loads(text)["points"][1] == [1, 2, 3]


def test_a_job_page_shows_its_completion_webhook(keyed):
    alice = {"Authorization": "Bearer key-a"}
    job = keyed.post("/v1/test-compute/jobs", params={"callback_url": "http://127.0.0.1:9/hook"}, json={"values": [1.0]},
                     headers=alice).json()
    wait_for(keyed, job["id"], headers=alice)
    page = keyed.get(f"/dashboard/jobs/{job['id']}", headers=alice).text
    assert "completion webhook" in page and 'title="http://127.0.0.1:9/hook"' in page
    assert "completion webhook" not in keyed.get(f"/dashboard/jobs/{_submit(keyed, [1.0], alice)['id']}", headers=alice).text


def _rows(html: str) -> dict[str, str]:
    return {m.group(1): m.group(0) for m in re.finditer(r'<tr data-job="([^"]+)".*?</tr>', html, re.S)}


def test_the_list_names_each_jobs_input(client):
    """An input column: the uploaded file's name, or 'JSON' for a JSON body."""
    body = _submit(client, [1.0])
    upload = client.post("/v1/test-compute/jobs", files={"file": ("rig run 7.txt", b"1\n2\n", "text/plain")}).json()
    wait_for(client, upload["id"])
    page = client.get("/dashboard").text
    assert "<th>input</th>" in page
    rows = _rows(page)
    assert re.search(r'<td class="input-name"[^>]*>rig run 7.txt</td>', rows[upload["id"]])
    assert re.search(r'<td class="input-name"[^>]*>JSON</td>', rows[body["id"]])


def test_a_finished_job_is_re_run_with_the_same_input(keyed):
    """'Re-run' on a finished job's page submits the same input as a new job of the same tenant (the JSON body;
    for an upload the stored file under its name with its options) and opens the new job's page."""
    alice = {"Authorization": "Bearer key-a"}
    log_in(keyed, "key-a")
    token = form_token(keyed.cookies["plantsolve_session"])
    first = _submit(keyed, [1.0, 2.5], headers=alice)
    page = keyed.get(f"/dashboard/jobs/{first['id']}").text
    assert f'action="/dashboard/jobs/{first["id"]}/rerun"' in page and "Re-run" in page
    assert keyed.post(f"/dashboard/jobs/{first['id']}/rerun", data={}).status_code == 403  # the form's token
    again = keyed.post(f"/dashboard/jobs/{first['id']}/rerun", data={"token": token}, follow_redirects=False)
    assert again.status_code == 303
    new_id = again.headers["location"].rsplit("/", 1)[-1]
    assert new_id != first["id"]
    assert wait_for(keyed, new_id, headers=alice)["status"] == "succeeded"
    assert keyed.get(f"/v1/jobs/{new_id}/result", headers=alice).json()["total"] == 3.5
    assert keyed.get(f"/v1/jobs/{new_id}/input", headers=alice).json() == {"values": [1.0, 2.5]}

    upload = keyed.post("/v1/test-compute/jobs", headers=alice, data={"options": '{"seconds": 0.01}'},
                        files={"file": ("values.txt", b"1\n2\n3\n", "text/plain")}).json()
    wait_for(keyed, upload["id"], headers=alice)
    again = keyed.post(f"/dashboard/jobs/{upload['id']}/rerun", data={"token": token}, follow_redirects=False)
    new_id = again.headers["location"].rsplit("/", 1)[-1]
    assert wait_for(keyed, new_id, headers=alice)["status"] == "succeeded"
    assert keyed.get(f"/v1/jobs/{new_id}/result", headers=alice).json()["total"] == 6.0
    described = keyed.get(f"/v1/jobs/{new_id}/input", headers=alice).json()
    assert described["filename"] == "values.txt" and described["options"] == {"seconds": 0.01}
    assert keyed.get(f"/v1/jobs/{new_id}/input/file", headers=alice).content == b"1\n2\n3\n"
    # another tenant cannot re-run it
    log_in(keyed, "key-b")
    token_b = form_token(keyed.cookies["plantsolve_session"])
    assert keyed.post(f"/dashboard/jobs/{upload['id']}/rerun", data={"token": token_b}).status_code == 404


def test_a_running_job_has_no_re_run(keyed):
    alice = {"Authorization": "Bearer key-a"}
    job = keyed.post("/v1/test-compute/jobs", json={"values": [1.0], "seconds": 20}, headers=alice).json()
    wait_for(keyed, job["id"], statuses=("running",), headers=alice)
    log_in(keyed, "key-a")
    assert "/rerun" not in keyed.get(f"/dashboard/jobs/{job['id']}").text
    refused = keyed.post(f"/dashboard/jobs/{job['id']}/rerun", data={"token": form_token(keyed.cookies["plantsolve_session"])})
    assert refused.status_code == 409 and "once it has finished" in refused.text
    keyed.post(f"/v1/jobs/{job['id']}/cancel", headers=alice)


def _options_of(page: str) -> tuple[dict, dict, dict]:
    """The upload form's options text, its defaults field and the options schema embedded in the page."""
    text = html.unescape(re.search(r'<textarea name="options"[^>]*>(.*?)</textarea>', page, re.S).group(1))
    defaults = html.unescape(re.search(r'name="option_defaults" value="([^"]*)"', page).group(1))
    schema = re.search(r'<script type="application/json" id="options-schema">(.*?)</script>', page, re.S).group(1)
    return json.loads(text), json.loads(defaults), json.loads(schema)


@pytest.mark.parametrize("kind", sorted(k for k, s in KINDS.items() if s.upload_extensions))
def test_every_upload_form_shows_its_options_with_defaults_and_their_schema(client, kind):
    spec = KINDS[kind]
    options, defaults, schema = _options_of(client.get(f"/dashboard/submit/{kind}").text)
    model = spec.request_model.model_fields["options"].annotation
    assert set(schema["properties"]) == set(model.model_fields)  # the fields the script generates
    expected = {name: json.loads(json.dumps(f.get_default(call_default_factory=True, validated_data={}),
                                            default=lambda m: m.model_dump(mode="json")))
                for name, f in model.model_fields.items() if not f.is_required()}
    expected = {k: v for k, v in expected.items() if v is not None}
    assert defaults == expected
    assert options == expected  # what the kind does with none sent: no value nobody typed
    model.model_validate(options)  # what the form shows is valid as it stands


def test_a_request_file_uploaded_with_the_form_untouched_keeps_its_own_options(client):
    """The form starts at the defaults and sends only changes, so a saved request's own options are not contradicted
    by values nobody typed (the example's were prefilled and sent: every flowmeter request file was refused)."""
    options, defaults, _ = _options_of(client.get("/dashboard/submit/flowmeter").text)
    request = KINDS["flowmeter"].example()
    request["options"] = {**request.get("options", {}), "probe_points": [[0.0, 0.0]]}
    response = client.post("/dashboard/submit/flowmeter", follow_redirects=False,
                           data={"source": "upload", "options": json.dumps(options),
                                 "option_defaults": json.dumps(defaults)},
                           files={"file": ("meter.json", json.dumps(request).encode(), "application/json")})
    assert response.status_code == 303, response.text[:2000]
    job_id = response.headers["location"].rsplit("/", 1)[-1]
    assert client.get(f"/v1/jobs/{job_id}/input").json()["options"] is None


def test_the_tube_upload_form_is_prefilled_with_its_defaults(client):
    options, _, schema = _options_of(client.get("/dashboard/submit/tube").text)
    assert options["bend_radius_model"] == "auto" and options["damping"] == 1.0 and options["seed"] == 0
    assert "bend_radius" in schema["properties"] and "bend_radius" not in options  # no default: a field left empty


def test_an_upload_sends_only_the_options_that_differ_from_the_defaults(client):
    """Options left at their defaults are not sent (a JSON file's own options stay); changed ones are."""
    _, defaults, _ = _options_of(client.get("/dashboard/submit/test-compute").text)
    assert defaults == {"seconds": 0.0}
    sent = {}
    for options in ('{"seconds": 0.0}', '{"seconds": 0.01}'):
        response = client.post("/dashboard/submit/test-compute", follow_redirects=False,
                               data={"source": "upload", "options": options, "option_defaults": json.dumps(defaults)},
                               files={"file": ("values.txt", b"1\n2\n", "text/plain")})
        job_id = response.headers["location"].rsplit("/", 1)[-1]
        wait_for(client, job_id)
        sent[options] = client.get(f"/v1/jobs/{job_id}/input").json()["options"]
    assert sent == {'{"seconds": 0.0}': None, '{"seconds": 0.01}': {"seconds": 0.01}}
