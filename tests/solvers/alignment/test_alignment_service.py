"""The alignment solver through the service: JSON and PCF submissions, the aligned PCF
artifact, bad input as 422 naming the field, and the CLI."""

from __future__ import annotations

import json

import pytest

from tests.conftest import REPO, run_plantsolve, wait_for

EXAMPLES = REPO / "examples" / "alignment"


@pytest.fixture(scope="module")
def client(tmp_path_factory):
    from fastapi.testclient import TestClient

    from plantsolve.app.main import create_app
    from tests.conftest import service_settings

    with TestClient(create_app(service_settings(tmp_path_factory.mktemp("alignment")))) as test_client:
        yield test_client


def _pcf_end_points(text: str) -> dict[str, list[tuple[float, float, float]]]:
    points: dict[str, list] = {}
    current = None
    for line in text.splitlines():
        words = line.split()
        if words and words[0] == "COMPONENT-IDENTIFIER":
            current = words[1]
            points[current] = []
        elif words and words[0] in ("END-POINT", "BRANCH1-POINT") and current is not None:
            points[current].append(tuple(words[1:4]))
    return points


def test_json_job_closes_every_connection(client):
    body = json.loads((EXAMPLES / "ladder.json").read_text())
    response = client.post("/v1/alignment/jobs", json=body)
    assert response.status_code == 202, response.text
    job = wait_for(client, response.json()["id"], timeout=180)
    assert job["status"] == "succeeded", job
    result = client.get(f"/v1/jobs/{job['id']}/result").json()
    assert result["converged"] is True
    assert result["max_position_error"] <= 1e-10 and result["max_angle_error"] <= 1e-10
    assert [c["id"] for c in result["components"]] == [c["id"] for c in body["components"]]
    assert len(result["connections"]) == len(body["connections"])
    fixed = {c["id"]: c for c in body["components"] if c.get("fixed")}
    for component in result["components"]:
        if component["id"] in fixed:  # tie-ins never move, not by one bit
            assert [p["position"] for p in component["ports"]] == [p["position"] for p in fixed[component["id"]]["ports"]]


def test_pcf_upload_gives_an_aligned_pcf_with_coincident_end_points(client):
    pcf = (EXAMPLES / "ladder.pcf").read_bytes()
    response = client.post("/v1/alignment/jobs", files={"file": ("ladder.pcf", pcf, "text/plain")})
    assert response.status_code == 202, response.text
    job = wait_for(client, response.json()["id"], timeout=180)
    assert job["status"] == "succeeded", job
    assert "aligned.pcf" in {a["name"] for a in job["artifacts"]}
    aligned = client.get(f"/v1/jobs/{job['id']}/artifacts/aligned.pcf").text
    assert "PIPELINE-REFERENCE 100-CW-1001" in aligned and "PIPING-SPEC A1" in aligned  # untouched attributes kept
    # Connected ports print the very same coordinates: count how often each printed point occurs.
    counts: dict[tuple, int] = {}
    for points in _pcf_end_points(aligned).values():
        for point in points:
            counts[point] = counts.get(point, 0) + 1
    result = client.get(f"/v1/jobs/{job['id']}/result").json()
    closed = sum(1 for c in result["connections"] if not c["cut"])
    assert sum(1 for n in counts.values() if n == 2) == closed


def test_bad_connections_are_422_naming_the_field(client):
    """Garbage files of every accepted extension: tests/service/test_kind_contract.py."""
    body = json.loads((EXAMPLES / "ladder.json").read_text())
    body["connections"][0]["to"] = ["NO-SUCH-COMPONENT", 0]
    response = client.post("/v1/alignment/jobs", json=body)
    assert response.status_code == 422 and response.headers["content-type"] == "application/problem+json"
    assert any(error["loc"][:2] == ["connections", 0] for error in response.json()["errors"]), response.json()
    body = json.loads((EXAMPLES / "ladder.json").read_text())
    body["components"][1]["ports"][0]["direction"] = [0.0, 0.0, 0.0]
    response = client.post("/v1/alignment/jobs", json=body)
    assert response.status_code == 422
    assert any(error["loc"][:2] == ["components", 1] for error in response.json()["errors"]), response.json()
    refused = client.post("/v1/alignment/jobs", files={"file": ("model.stl", b"solid", "model/stl")})
    assert refused.status_code == 415 and ".pcf" in refused.json()["detail"], refused.text


def test_a_pcf_with_items_failing_the_model_check_is_accepted_and_only_a_file_of_rings_refused(client):
    """The submission check passes on an interpreted PCF with an item that would fail it (that item is held);
    a file with nothing but a handwheel ring is a 422 naming its lines."""
    pcf = (b"UNITS-CO-ORDS MM\nPIPE\n    END-POINT 0 0 0 100\n    END-POINT 1000 0 0 100\n"
           b"BEND\n    END-POINT 1000 0 0 100\n    END-POINT 1300 0 0 100\n    CENTRE-POINT 900 -20 0\n"
           b"PIPE\n    END-POINT 1300 0 0 100\n    END-POINT 2300 0 0 100\n")
    response = client.post("/v1/alignment/jobs", files={"file": ("line.pcf", pcf, "text/plain")})
    assert response.status_code == 202, response.text  # what the solve reports: test_alignment_pcf_model_check
    ring = (b"UNITS-CO-ORDS MM\nBEND\n    END-POINT 0 0 0 25\n    END-POINT 500 0 0 25\n    CENTRE-POINT 250 0 0\n"
            b"BEND\n    END-POINT 500 0 0 25\n    END-POINT 0 0 0 25\n    CENTRE-POINT 250 0 0\n")
    refused = client.post("/v1/alignment/jobs", files={"file": ("wheel.pcf", ring, "text/plain")})
    assert refused.status_code == 422, refused.text
    assert "line 2" in refused.text and "line 6" in refused.text


def test_cli_aligns_the_pcf_example(tmp_path):
    done = run_plantsolve(["solve", "alignment", str(EXAMPLES / "ladder.pcf"), "-o", str(tmp_path / "aligned.json")], tmp_path)
    assert done.returncode == 0, done.stderr
    assert json.loads((tmp_path / "aligned.json").read_text())["converged"] is True
    assert (tmp_path / "aligned_artifacts" / "aligned.pcf").exists()
