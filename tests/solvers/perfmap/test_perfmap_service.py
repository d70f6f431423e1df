"""The perfmap solver through the service: JSON and CSV submissions, artifacts, the inverse
query endpoint and bad input as 422 — on the real N+3 fan map (pyCycle, Apache-2.0; see
examples/perfmap/README.md). The CLI's run of this map is tests/cli/test_cli.py's (one subprocess solve)."""

from __future__ import annotations

import json

import pytest

from tests.conftest import REPO, wait_for

EXAMPLES = REPO / "examples" / "perfmap"


@pytest.fixture(scope="module")
def finished(tmp_path_factory):
    from fastapi.testclient import TestClient

    from plantsolve.app.main import create_app
    from tests.conftest import service_settings

    with TestClient(create_app(service_settings(tmp_path_factory.mktemp("perfmap")))) as client:
        body = (EXAMPLES / "n3_fan_map.json").read_bytes()
        response = client.post("/v1/perfmap/jobs", content=body, headers={"Content-Type": "application/json"})
        assert response.status_code == 202, response.text
        yield client, wait_for(client, response.json()["id"], timeout=180)


def test_json_job_succeeds_with_map_and_plots(finished):
    client, job = finished
    assert job["status"] == "succeeded", job
    result = client.get(f"/v1/jobs/{job['id']}/result").json()
    assert len(result["settings"]) == 18
    grid = result["map"]
    efficiencies = [e for row in grid["efficiency"] for e in row if e is not None]
    assert efficiencies and 0.85 < max(efficiencies) <= 1.0  # measured peak 0.9495; efficiency is physical
    assert any(e is None for row in grid["efficiency"] for e in row)  # unreachable nodes are null, never 0
    names = {a["name"] for a in job["artifacts"]}
    assert {"map.png", "map.svg", "characteristics.png", "envelopes.png"} <= names
    png = client.get(f"/v1/jobs/{job['id']}/artifacts/map.png")
    assert png.status_code == 200 and png.headers["content-type"] == "image/png" and png.content[:8] == b"\x89PNG\r\n\x1a\n"


def test_inverse_query_answers_feasible_and_infeasible_points(finished):
    client, job = finished
    answer = client.post(f"/v1/perfmap/jobs/{job['id']}/query", json=json.loads((EXAMPLES / "query.json").read_text()))
    assert answer.status_code == 200, answer.text
    points = answer.json()["points"]
    assert [p["feasible"] for p in points] == [True, True, False]
    assert points[2]["distance_to_map"] > 0 and points[2]["theta"] is None
    for point in points[:2]:
        assert 0.0 <= point["theta"] <= 5.0 and 0.5 <= point["phi"] <= 1.1 and 0 < point["efficiency"] < 1
    single = client.post(f"/v1/perfmap/jobs/{job['id']}/query", json={"flow": 2000.0, "pressure": 1.15})
    alone = single.json()["points"][0]
    assert alone["feasible"] and all(alone[k] == pytest.approx(points[0][k], abs=1e-5) for k in ("theta", "phi", "efficiency"))


def test_query_errors(finished):
    client, job = finished
    bad = client.post(f"/v1/perfmap/jobs/{job['id']}/query", json={"points": [{"flow": 1.0}]})
    assert bad.status_code == 422 and ["points", 0, "pressure"] in [e["loc"] for e in bad.json()["errors"]]
    missing = client.post("/v1/perfmap/jobs/00000000-0000-0000-0000-000000000000/query", json={"flow": 1, "pressure": 1})
    assert missing.status_code == 404
    other = client.post("/v1/test-compute/jobs", json={"values": [1.0]}).json()
    assert client.post(f"/v1/perfmap/jobs/{other['id']}/query", json={"flow": 1, "pressure": 1}).status_code == 404


def test_csv_upload_and_bad_tables(finished):
    client, _ = finished
    csv = (EXAMPLES / "n3_fan_map.csv").read_bytes()
    response = client.post(
        "/v1/perfmap/jobs", files={"file": ("fan.csv", csv, "text/csv")}, data={"options": json.dumps({"map": False})}
    )
    assert response.status_code == 202, response.text
    done = wait_for(client, response.json()["id"], timeout=180)
    assert done["status"] == "succeeded" and client.get(f"/v1/jobs/{done['id']}/result").json()["map"] is None
    too_few = b"theta,phi,flow,pressure,efficiency\n0,0.5,1,1.1,0.5\n0,0.5,2,1.0,0.6\n"
    rejected = client.post("/v1/perfmap/jobs", files={"file": ("two.csv", too_few, "text/csv")})
    assert rejected.status_code == 422 and rejected.headers["content-type"] == "application/problem+json"
    nan = {"positions": [{"theta": 0, "phi": 0.5, "flow": [1, 2, 3], "pressure": [1.2, 1.1, float("nan")], "efficiency": [0.5, 0.6, 0.5]}]}
    body = json.dumps(nan).encode()  # json.dumps writes NaN literally
    assert client.post("/v1/perfmap/jobs", content=body, headers={"Content-Type": "application/json"}).status_code == 422
    for name, content in (("m.txt", b"theta"), ("rig.xls", b"\xd0\xcf\x11\xe0")):  # an old Excel workbook too
        refused = client.post("/v1/perfmap/jobs", files={"file": (name, content, "application/octet-stream")})
        assert refused.status_code == 415 and ".xlsx" in refused.json()["detail"], refused.text


def test_units_xlsx_upload_and_csv_exports_through_the_service(finished):
    """The JSON example states its units and the result repeats them; an Excel rig table uploads like a
    CSV, a wrong unit is a 422 naming the header, and map.csv / curves.csv download with units."""
    import io

    import openpyxl

    client, job = finished
    result = client.get(f"/v1/jobs/{job['id']}/result").json()
    assert result["units"] == {"flow": "lbm/s", "pressure": "1", "efficiency": "1", "settings": ["deg", "-"]}
    exported = client.get(f"/v1/jobs/{job['id']}/artifacts/curves.csv")
    assert exported.status_code == 200 and exported.text.splitlines()[0] == (
        "theta [deg],phi [-],t [-],flow [lbm/s],pressure [-],efficiency [-]")
    grid = client.get(f"/v1/jobs/{job['id']}/artifacts/map.csv")
    assert grid.text.splitlines()[0].startswith("flow [lbm/s],pressure [-],max efficiency [-]")

    rows = [ln.split(",") for ln in (EXAMPLES / "n3_fan_map.csv").read_text().splitlines()[1:]]
    wb = openpyxl.Workbook()
    ws = wb.active
    ws.title = "Rig"
    ws.append(["IGV [deg]", "Nc [-]", "Wc [lbm/s]", "PR", "eff"])
    for r in rows:
        ws.append([float(v) for v in r])
    buf = io.BytesIO()
    wb.save(buf)
    xlsx = buf.getvalue()
    kind = "application/vnd.openxmlformats-officedocument.spreadsheetml.sheet"
    response = client.post("/v1/perfmap/jobs", files={"file": ("rig.xlsx", xlsx, kind)},
                           data={"options": json.dumps({"map": False, "result_units": {"flow": "kg/s"}})})
    assert response.status_code == 202, response.text
    done = wait_for(client, response.json()["id"], timeout=180)
    assert done["status"] == "succeeded", done
    res = client.get(f"/v1/jobs/{done['id']}/result").json()
    assert res["units"]["flow"] == "kg/s" and res["setting_names"] == ["IGV", "Nc"]
    assert res["flow_range"][1] == pytest.approx(result["flow_range"][1] * 0.45359237, rel=1e-9)

    ws["C1"] = "Wc [kg]"
    buf = io.BytesIO()
    wb.save(buf)
    bad = client.post("/v1/perfmap/jobs", files={"file": ("rig.xlsx", buf.getvalue(), kind)})
    assert bad.status_code == 422, bad.text
    error = bad.json()["errors"][0]
    assert error["loc"] == ["file", "header"] and "'Wc [kg]'" in error["msg"]
