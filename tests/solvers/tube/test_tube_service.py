"""The tube solver through the service: JSON and PLY/XYZ/NPY-base64 submissions, the CNC data
(LRA, XYZ+CLR) and mesh artifacts, bad scans as 422, and the CLI."""

from __future__ import annotations

import base64
import csv
import io
import json

import numpy as np
import pytest

from tests.conftest import REPO, run_plantsolve, wait_for

EXAMPLES = REPO / "examples" / "tube"

NOMINAL_ANGLES = [90.0, 45.0, 30.0]  # the example's nominal bends (see examples/tube/README.md)


@pytest.fixture(scope="module")
def client(tmp_path_factory):
    from fastapi.testclient import TestClient

    from plantsolve.app.main import create_app
    from tests.conftest import service_settings

    with TestClient(create_app(service_settings(tmp_path_factory.mktemp("tube")))) as test_client:
        yield test_client


@pytest.fixture(scope="module")
def json_job(client):
    body = (EXAMPLES / "scan_request.json").read_bytes()
    response = client.post("/v1/tube/jobs", content=body, headers={"Content-Type": "application/json"})
    assert response.status_code == 202, response.text
    return wait_for(client, response.json()["id"], timeout=240)


def _bend_angles(result: dict) -> list[float]:
    return [row["angle"] for row in result["lra"][:-1]]


def test_json_scan_reconstructs_three_bends_with_cnc_data(client, json_job):
    assert json_job["status"] == "succeeded", json_job
    result = client.get(f"/v1/jobs/{json_job['id']}/result").json()
    lra = result["lra"]
    assert len(lra) == 4 and lra[0]["rotation"] == 0 and lra[-1]["angle"] == 0
    # The scanned tube sprang back 0.5-1 degree from its nominal 90/45/30.
    for measured, nominal in zip(_bend_angles(result), NOMINAL_ANGLES):
        assert abs(measured - nominal) < 2.0
    assert result["pipe_radius"] == pytest.approx(6.0, rel=0.03)
    names = {a["name"] for a in json_job["artifacts"]}
    assert {"tube.stl", "tube.glb", "deviation.ply", "lra.csv", "xyz_clr.csv", "overview.png"} <= names
    table = client.get(f"/v1/jobs/{json_job['id']}/artifacts/lra.csv").text
    rows = list(csv.reader(io.StringIO(table)))
    assert len(rows) >= 5  # header + 4 LRA rows
    stl = client.get(f"/v1/jobs/{json_job['id']}/artifacts/tube.stl")
    assert stl.status_code == 200 and len(stl.content) > 1000


def test_ply_and_npy_base64_give_the_same_bends(client, json_job):
    reference = _bend_angles(client.get(f"/v1/jobs/{json_job['id']}/result").json())
    ply = client.post("/v1/tube/jobs", files={"file": ("scan.ply", (EXAMPLES / "scan.ply").read_bytes(), "application/octet-stream")})
    assert ply.status_code == 202, ply.text
    points = np.asarray(json.loads((EXAMPLES / "scan_request.json").read_text())["points"], dtype=float)
    buffer = io.BytesIO()
    np.save(buffer, points)
    npy = client.post("/v1/tube/jobs", json={"points": {"npy_base64": base64.b64encode(buffer.getvalue()).decode()}})
    assert npy.status_code == 202, npy.text
    for response in (ply, npy):
        done = wait_for(client, response.json()["id"], timeout=240)
        assert done["status"] == "succeeded", done
        angles = _bend_angles(client.get(f"/v1/jobs/{done['id']}/result").json())
        assert len(angles) == 3
        assert np.allclose(angles, reference, atol=0.5)  # PLY stores float32 coordinates


def test_bad_scans_are_422(client):
    """Garbage files of every accepted extension: tests/service/test_kind_contract.py."""
    few = client.post("/v1/tube/jobs", json={"points": [[0, 0, 0], [1, 0, 0], [2, 0, 0]]})
    assert few.status_code == 422 and few.headers["content-type"] == "application/problem+json"
    nan = client.post("/v1/tube/jobs", content=b'{"points": [[0, 0, NaN]]}', headers={"Content-Type": "application/json"})
    assert nan.status_code == 422 and nan.json()["errors"][0]["loc"][0] == "points"
    line = [[float(i), 0.0, 0.0] for i in range(500)]  # all points on a line: no surface to fit
    assert client.post("/v1/tube/jobs", json={"points": line}).status_code == 422


def test_unsupported_file_types_are_refused_at_intake(client):
    """The parser reads only what intake let through: the extension is checked there, once."""
    dwg = client.post("/v1/tube/jobs", files={"file": ("scan.dwg", b"AC1032", "application/octet-stream")})
    assert dwg.status_code == 415 and ".ply" in dwg.json()["detail"]


def test_cli_reads_the_xyz_scan(tmp_path):
    done = run_plantsolve(["solve", "tube", str(EXAMPLES / "scan.xyz"), "-o", str(tmp_path / "tube.json")], tmp_path)
    assert done.returncode == 0, done.stderr
    assert len(json.loads((tmp_path / "tube.json").read_text())["lra"]) == 4
    assert (tmp_path / "tube_artifacts" / "xyz_clr.csv").exists()


def test_a_truncated_upload_succeeds_with_its_skipped_lines_and_a_las_in_metres_comes_out_in_mm(client, tmp_path):
    """Through intake and the job store: the reader's warnings and unit conversion reach the stored result."""
    import laspy

    lines = (EXAMPLES / "scan.xyz").read_text().splitlines()
    lines[41] = "12.5 7.25"  # a line cut short
    cut = "\n".join(lines)[:-3]  # and the file ends mid-line
    xyz = client.post("/v1/tube/jobs", files={"file": ("scan.xyz", cut.encode(), "text/plain")})
    assert xyz.status_code == 202, xyz.text
    points = np.asarray(json.loads((EXAMPLES / "scan_request.json").read_text())["points"], dtype=float) / 1000.0
    header = laspy.LasHeader(point_format=3, version="1.2")
    header.scales, header.offsets = np.array([1e-7] * 3), points.min(axis=0)
    las = laspy.LasData(header)
    las.x, las.y, las.z = points.T
    buffer = io.BytesIO()
    las.write(buffer)
    las_job = client.post("/v1/tube/jobs", files={"file": ("scan.las", buffer.getvalue(), "application/octet-stream")})
    assert las_job.status_code == 202, las_job.text
    done = wait_for(client, xyz.json()["id"], timeout=240)
    assert done["status"] == "succeeded", done
    report = client.get(f"/v1/jobs/{done['id']}/result").json()["report"]
    assert report["status"] == "warning"
    skipped = next(w for w in report["warnings"] if w["code"] == "records_skipped")
    assert 42 in skipped["details"]["lines"] and report["details"]["source"]["truncated"]
    done = wait_for(client, las_job.json()["id"], timeout=240)
    assert done["status"] == "succeeded", done
    result = client.get(f"/v1/jobs/{done['id']}/result").json()
    assert result["units"] == "mm" and result["pipe_radius"] == pytest.approx(6.0, rel=0.03)
    assert result["report"]["details"]["source"]["units"]["factor"] == pytest.approx(1000.0)
    assert "file_units_assumed" in [w["code"] for w in result["report"]["warnings"]]
