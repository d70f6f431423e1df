"""The rigidity kind through the service and the CLI: JSON and LDraw submissions, the graph artifact,
and 422s naming the field."""

from __future__ import annotations

import json

import pytest

from plantsolve.schemas.rigidity import RigidityRequest
from plantsolve.solvers.base import InputRejected
from plantsolve.solvers.rigidity import synthetic
from plantsolve.solvers.rigidity.validation import check_input
from tests.conftest import REPO, run_plantsolve, wait_for

EXAMPLES = REPO / "examples" / "rigidity"


def _result(client, response):
    assert response.status_code == 202, response.text
    job = wait_for(client, response.json()["id"], timeout=60)
    assert job["status"] == "succeeded", job
    return job, client.get(f"/v1/jobs/{job['id']}/result").json()


def test_json_example_through_the_api(client):
    body = json.loads((EXAMPLES / "four_bar_and_door.json").read_text())
    job, result = _result(client, client.post("/v1/rigidity/jobs", json=body))
    assert result["dof"] == 2 and result["generic_dof"] == 0 and result["special_position"]
    names = {a["name"]: a for a in job["artifacts"]}
    assert set(names) == {"graph.png", "clusters.csv"}
    assert client.get(names["graph.png"]["url"]).content.startswith(b"\x89PNG")
    table = client.get(names["clusters.csv"]["url"]).text.splitlines()
    assert table[0] == "body,cluster,superbrick" and len(table) == 1 + 5


def test_ldraw_upload_through_the_api(client):
    content = (EXAMPLES / "hinged_wall.ldr").read_bytes()
    _, result = _result(client, client.post("/v1/rigidity/jobs", files={"file": ("hinged_wall.ldr", content)}))
    assert result["length_unit"] == "ldu" and result["dof"] == 4 and result["rank_method"] == "modular"
    assert ["L7", "L8", "L11", "L18", "L19"] in result["clusters"]
    assert result["collisions"] == []


@pytest.mark.parametrize("change, loc", [
    (lambda b: b["joints"][0].update(bodies=["ground", "nobody"]), ["joints", 0, "bodies", 1]),
    (lambda b: b["joints"][1].update(axis=[0, 0, 0]), ["joints", 1, "axis"]),
    (lambda b: b["joints"][2].update(bodies=["coupler", "coupler"]), ["joints", 2, "bodies"]),
    (lambda b: b["joints"][0].pop("axis"), ["joints", 0, "axis"]),
    (lambda b: b["joints"][3].update(id="J1"), ["joints", 3, "id"]),
    (lambda b: b.update(parts=[{"id": "p", "part": "3001", "position": [0, 0, 0]}]), ["parts"]),
])
def test_bad_requests_are_422_naming_the_field(client, change, loc):
    body = synthetic.four_bar()
    change(body)
    problem = client.post("/v1/rigidity/jobs", json=body).json()
    assert problem["status"] == 422 and problem["errors"][0]["loc"] == loc, problem


def test_a_file_type_rigidity_does_not_read_is_415(client):
    # the intake checks the extension against SPEC.upload_extensions; parse_upload never sees the file
    problem = client.post("/v1/rigidity/jobs", files={"file": ("model.lxf", b"PK\x03\x04")}).json()
    assert problem["status"] == 415 and "'.lxf'" in problem["detail"] and ".ldr, .mpd, .json" in problem["detail"]


def test_nan_is_422_naming_the_field(client):
    text = json.dumps(synthetic.four_bar()).replace('"point": [0, 0, 0]', '"point": [NaN, 0, 0]', 1)
    problem = client.post("/v1/rigidity/jobs", content=text, headers={"Content-Type": "application/json"}).json()
    assert problem["status"] == 422 and problem["errors"][0]["loc"][:3] == ["joints", 0, "point"]


def test_check_input_names_parts_and_dock_fields():
    body = {"parts": [{"id": "a", "part": "3001", "position": [0, 0, 0], "rotation": [1, 0, 0, 0, 2, 0, 0, 0, 1]},
                      {"id": "a", "part": "3001", "position": [0, -24, 0]}], "options": {"dock": {"part": "nope"}}}
    with pytest.raises(InputRejected) as info:
        check_input(RigidityRequest.model_validate(body))
    locs = [e.loc for e in info.value.errors]
    assert ("parts", 1, "id") in locs and ("parts", 0, "rotation") in locs and ("options", "dock", "part") in locs


def test_cli_solves_an_ldraw_file(tmp_path):
    (tmp_path / "model.ldr").write_bytes((EXAMPLES / "hinged_wall.ldr").read_bytes())
    done = run_plantsolve(["solve", "rigidity", "model.ldr", "-o", "out.json"], tmp_path)
    assert done.returncode == 0, done.stderr
    result = json.loads((tmp_path / "out.json").read_text())
    assert result["dof"] == 4 and result["generic_dof"] == 2


def test_a_cut_ldraw_upload_succeeds_with_the_warning_in_the_jobs_report(client):
    from tests.solvers.rigidity.ldraw_files import LDCAD_TECHNIC

    text = LDCAD_TECHNIC[:LDCAD_TECHNIC.rindex("3004.dat") + 2]
    job, result = _result(client, client.post("/v1/rigidity/jobs", files={"file": ("technic.ldr", text.encode())}))
    last = text.count("\n") + 1
    assert job["report"]["status"] == "warning"
    (cut,) = [w for w in job["report"]["warnings"] if w["code"] == "truncated_file"]
    assert cut["details"]["line"] == last and result["report"]["warnings"] == job["report"]["warnings"]
    problem = client.post("/v1/rigidity/jobs", files={"file": ("cut.ldr", b"0 x\n1 4 0 0 0 1 0 0 0 1 0 0 0 1 300")}).json()
    assert problem["status"] == 422 and problem["errors"][0]["loc"] == ["file"]
