"""The polyhedra kind through the service and the CLI: JSON and IDF submissions, artifacts, 422s naming
the field or the file line."""

from __future__ import annotations

import json

import pytest

from tests.conftest import REPO, run_plantsolve, wait_for

EXAMPLES = REPO / "examples" / "polyhedra"


def _result(client, response):
    assert response.status_code == 202, response.text
    job = wait_for(client, response.json()["id"], timeout=60)
    assert job["status"] == "succeeded", job
    return job, client.get(f"/v1/jobs/{job['id']}/result").json()


def test_idf_upload_through_the_api(client):
    content = (EXAMPLES / "two_offices.idf").read_bytes()
    job, result = _result(client, client.post("/v1/polyhedra/jobs", files={"file": ("two_offices.idf", content)}))
    assert [z["volume"] for z in result["zones"]] == pytest.approx([60.0, 60.0])
    assert result["adjacency"][0]["area"] == pytest.approx(12.0)
    names = {a["name"]: a for a in job["artifacts"]}
    assert set(names) == {"zones.png", "zones.csv"}
    png = client.get(names["zones.png"]["url"]).content
    assert png.startswith(b"\x89PNG")
    table = client.get(names["zones.csv"]["url"]).text.splitlines()
    assert table[0].startswith("record,id,zones,parent,volume [m3]") and len(table) == 1 + 2 + 13


def test_json_example_through_the_api(client):
    body = json.loads((EXAMPLES / "gable_house.json").read_text())
    _, result = _result(client, client.post("/v1/polyhedra/jobs", json=body))
    (zone,) = result["zones"]
    assert zone["volume"] == pytest.approx(320.0) and zone["net_surface_area"] == pytest.approx(zone["surface_area"] - 4.5)


def test_bad_requests_are_422_naming_the_field_or_line(client):
    body = {"vertices": [[0, 0, 0], [1, 0, 0], [0, 1, 0]], "faces": [{"id": "a", "loops": [[0, 1, 5]]}]}
    problem = client.post("/v1/polyhedra/jobs", json=body).json()
    assert problem["status"] == 422 and problem["errors"][0]["loc"] == ["faces", 0, "loops", 0, 2]
    body = {"faces": [{"id": "w", "parent": "nowhere", "loops": [[[0, 0, 0], [1, 0, 0], [0, 1, 0]]]}]}
    problem = client.post("/v1/polyhedra/jobs", json=body).json()
    assert problem["status"] == 422 and problem["errors"][0]["loc"] == ["faces", 0, "parent"]
    idf = b"Version,9.3;\nBuildingSurface:Detailed, W1, Wall, C, Z, Outdoors, , SunExposed, WindExposed, 0.5, 3,\n" \
          b"0, 0, 0, 1, 0, 0, 1, 0, x;\n"
    problem = client.post("/v1/polyhedra/jobs", files={"file": ("bad.idf", idf)}).json()
    assert problem["status"] == 422 and problem["errors"][0]["loc"] == ["file", "line", 2]


def test_cli_solves_an_idf(tmp_path):
    (tmp_path / "building.idf").write_bytes((EXAMPLES / "two_offices.idf").read_bytes())
    done = run_plantsolve(["solve", "polyhedra", "building.idf", "-o", "out.json"], tmp_path)
    assert done.returncode == 0, done.stderr
    result = json.loads((tmp_path / "out.json").read_text())
    assert result["total_volume"] == pytest.approx(120.0)
    assert (tmp_path / "out_artifacts" / "zones.csv").exists()


def test_an_idf_asked_in_feet_through_the_api_is_converted_and_says_so(client):
    content = (EXAMPLES / "two_offices.idf").read_bytes()
    job, result = _result(client, client.post("/v1/polyhedra/jobs", files={"file": ("two_offices.idf", content)},
                                              data={"options": json.dumps({"units": "ft"})}))
    assert result["units"] == "ft" and result["total_volume"] == pytest.approx(4237.76, abs=0.01)
    assert result["total_floor_area"] == pytest.approx(40 / 0.3048 ** 2)
    assert result["report"]["details"]["source"]["units"]["factor"] == pytest.approx(1 / 0.3048)
    table = client.get({a["name"]: a for a in job["artifacts"]}["zones.csv"]["url"]).text.splitlines()
    header = table[0].split(",")
    assert "volume [ft3]" in header and header[-3:] == ["floor_area [ft2]", "multiplier", "part_of_total_floor_area"]
    assert float(table[1].split(",")[-3]) == pytest.approx(20 / 0.3048 ** 2)


def test_an_absurd_option_and_another_kinds_file_are_422_at_submission(client):
    body = json.loads((EXAMPLES / "gable_house.json").read_text())
    problem = client.post("/v1/polyhedra/jobs", json={**body, "options": {"merge_tolerance": 0.3}}).json()
    assert problem["status"] == 422 and problem["errors"][0]["loc"] == ["options", "merge_tolerance"]
    tube = (REPO / "plantsolve" / "solvers" / "tube" / "example.json").read_bytes()
    problem = client.post("/v1/polyhedra/jobs", files={"file": ("scan.json", tube)}).json()
    assert problem["status"] == 422 and "a tube request" in problem["errors"][0]["msg"]
