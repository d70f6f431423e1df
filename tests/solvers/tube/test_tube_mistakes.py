"""Mistakes users make with the tube kind, each as they would make it, and the answer it gets: a refusal at
submission naming the field or what the file holds, a warning naming the quantity, or a verdict that tells the
truth (a failed or incomparable inspection is the job's outcome, not a footnote)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from plantsolve.schemas.tube import TubeOptions, TubeRequest
from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.tube.artifacts import figures
from plantsolve.solvers.tube.scan import TubeScan
from plantsolve.solvers.tube.solve import solve
from plantsolve.solvers.tube.synthetic import make_model
from plantsolve.solvers.tube.upload import parse_upload
from plantsolve.solvers.tube.validation import check_input, implausible_against_scan, sample_spacing, scan_extent
from tests.conftest import REPO, wait_for
from tests.support.plots import check_figure

EXAMPLES = REPO / "examples"
EXAMPLE = json.loads((EXAMPLES / "tube" / "scan_request.json").read_text())
POINTS = np.asarray(EXAMPLE["points"], float)


@pytest.fixture(scope="module")
def client(tmp_path_factory):
    from fastapi.testclient import TestClient

    from plantsolve.app.main import create_app
    from tests.conftest import service_settings

    with TestClient(create_app(service_settings(tmp_path_factory.mktemp("tube_mistakes")))) as test_client:
        yield test_client


def _refusal(response) -> str:
    assert response.status_code == 422, response.text
    assert response.headers["content-type"] == "application/problem+json"
    errors = response.json()["errors"]
    return " ".join(f"{'/'.join(map(str, e['loc']))}: {e['msg']}" for e in errors)


# --- files of another kind --------------------------------------------------------------------------------------


def test_a_perfmap_csv_uploaded_to_tube_is_refused_naming_its_columns(client):
    content = (EXAMPLES / "perfmap" / "n3_fan_map.csv").read_bytes()
    text = _refusal(client.post("/v1/tube/jobs", files={"file": ("n3_fan_map.csv", content, "text/csv")}))
    assert text.startswith("file: ") and "theta, phi, flow, pressure, efficiency" in text and "x, y, z" in text


@pytest.mark.parametrize("path", ["perfmap/n3_fan_map.json", "flowmeter/meter.json", "alignment/ladder.json"])
def test_another_kinds_json_request_uploaded_to_tube_is_refused_naming_what_it_holds(client, path):
    content = (EXAMPLES / path).read_bytes()
    text = _refusal(client.post("/v1/tube/jobs", files={"file": (path.split("/")[-1], content, "application/json")}))
    keys = sorted(json.loads(content))
    assert text.startswith("file: ") and ", ".join(keys[:3]) in text and "`points`" in text


def test_a_perfmap_table_without_its_header_is_refused_as_points_on_few_planes(client):
    lines = (EXAMPLES / "perfmap" / "n3_fan_map.csv").read_text().splitlines()[1:]
    text = _refusal(client.post("/v1/tube/jobs", files={"file": ("map.csv", "\n".join(lines).encode(), "text/csv")}))
    # theta takes 2 values, phi 9: every "sample" lies on 2 parallel planes
    assert text.startswith("points: the x coordinates take only 2 distinct values over 134 points")


def test_a_surveyors_header_names_the_axes():
    rows = np.column_stack([POINTS[:, 1], POINTS[:, 0], POINTS[:, 2]])
    request = parse_upload(_csv("Northing,Easting,Elevation", rows), {})
    np.testing.assert_allclose(np.asarray(request.points, float), POINTS, atol=1e-6)


def test_an_lra_table_given_as_the_scan_is_refused_pointing_to_nominal_csv(client):
    # the service's own lra.csv, and the same table without its header
    with_header = (EXAMPLES / "tube" / "nominal_lra.csv").read_bytes()
    text = _refusal(client.post("/v1/tube/jobs", files={"file": ("nominal.csv", with_header, "text/csv")}))
    assert "row, length_mm, rotation_deg, angle_deg, bend_radius_mm" in text and "options.nominal_csv" in text
    bare = b"80 0 90 18\n45 90 45 18\n30 -45 30 18\n70 0 0 0\n"
    text = _refusal(client.post("/v1/tube/jobs", files={"file": ("nominal.txt", bare, "text/plain")}))
    assert "4 rows of 4 numbers" in text and "options.nominal_csv" in text
    xyz_clr = (EXAMPLES / "tube" / "nominal_xyz_clr.csv").read_bytes()
    assert "options.nominal_csv" in _refusal(client.post("/v1/tube/jobs",
                                                          files={"file": ("n.csv", xyz_clr, "text/csv")}))


def _csv(header: str, rows: np.ndarray) -> StoredInput:
    body = "\n".join([header] + [",".join(f"{v:.6f}" for v in r) for r in rows])
    return StoredInput.from_bytes("scan.csv", body.encode())


def test_a_header_naming_x_y_z_elsewhere_is_read_from_those_columns_in_its_unit():
    # an index column first, the coordinates in metres as the header says, intensity last
    rows = np.column_stack([np.arange(len(POINTS)), POINTS / 1000.0, np.full(len(POINTS), 0.5)])
    request = parse_upload(_csv("index,x [m],y [m],z [m],intensity", rows), {})
    got = np.asarray(request.points, float)
    np.testing.assert_allclose(got, POINTS, atol=1e-3)  # 6 decimals of a metre
    units = request.source.units
    assert (units.file_unit, units.factor, units.basis) == ("m", pytest.approx(1000.0), "header")
    # the option still overrides what the header says
    request = parse_upload(_csv("index,x_m,y_m,z_m,intensity", rows), {"file_units": "mm"})
    assert request.source.units.basis == "options.file_units"
    np.testing.assert_allclose(np.asarray(request.points, float), POINTS / 1000.0, atol=1e-6)


def test_a_comment_or_free_text_above_the_points_is_no_column_header():
    lines = ["// exported by scanner", "# x y z"] + [" ".join(f"{v:.4f}" for v in p) for p in POINTS]
    request = parse_upload(StoredInput.from_bytes("scan.xyz", "\n".join(lines).encode()), {})
    np.testing.assert_allclose(np.asarray(request.points, float), POINTS, atol=1e-4)
    assert request.source.units.basis == "request"


def test_a_header_of_other_columns_with_x_y_z_first_is_still_refused():
    rows = np.column_stack([POINTS, np.ones(len(POINTS))])
    with pytest.raises(InputRejected) as exc:
        parse_upload(_csv("flow,pressure,speed,efficiency", rows), {})
    assert "flow, pressure, speed, efficiency" in exc.value.errors[0].msg


# --- absurd scalars ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize("field, value", [("pipe_radius", 1e300), ("bend_radius", 1e300), ("tolerance", 1e9),
                                          ("dies", [18.0, 1e300]), ("damping", 50.0), ("seed", 2 ** 64),
                                          ("inspection_tolerances", {"angle": 720.0}),
                                          ("inspection_tolerances", {"length": 1e300})])
def test_absurd_scalars_are_refused_at_intake_naming_the_field(client, field, value):
    body = {"points": EXAMPLE["points"], "options": {field: value}}
    text = _refusal(client.post("/v1/tube/jobs", json=body))
    assert text.startswith(f"options/{field}")


def test_every_scalar_option_has_physical_bounds_in_the_schema():
    schema = TubeOptions.model_json_schema()
    defs = schema["$defs"]
    unbounded = []

    def walk(props: dict, where: str) -> None:
        for name, prop in props.items():
            variants = prop.get("anyOf", [prop])
            for v in variants:
                if "$ref" in v:
                    ref = defs[v["$ref"].rsplit("/", 1)[-1]]
                    if where == "options" and "properties" in ref:
                        walk(ref["properties"], f"{where}.{name}")
                    continue
                if v.get("type") == "array" and v.get("items", {}).get("type") == "number":
                    v = v["items"]
                if v.get("type") in ("number", "integer"):
                    lower = "minimum" in v or "exclusiveMinimum" in v
                    upper = "maximum" in v or "exclusiveMaximum" in v
                    if not (lower and upper):
                        unbounded.append(f"{where}.{name}")
    walk(schema["properties"], "options")
    assert unbounded == []


def test_a_pipe_radius_larger_than_the_scan_is_refused_at_submission(client):
    body = {"points": EXAMPLE["points"], "options": {"pipe_radius": 6000.0}}  # 6 m on a scan 284 mm across
    text = _refusal(client.post("/v1/tube/jobs", json=body))
    assert text.startswith("options/pipe_radius: implausible pipe radius: 6000 mm is larger than the whole scan")


def test_a_pipe_radius_far_under_the_sample_spacing_is_refused():
    spacing = sample_spacing(POINTS)
    assert 0.2 < spacing < 2.0  # 4,000 samples on a 12 mm tube 280 mm long
    scan = TubeScan(TubeRequest(points=EXAMPLE["points"], options={"pipe_radius": 0.006}))  # 6 mm typed as metres
    with pytest.raises(InputRejected) as exc:
        check_input(scan)
    assert exc.value.errors[0].loc == ("options", "pipe_radius") and "spacing" in exc.value.errors[0].msg


@pytest.mark.parametrize("options, loc", [({"bend_radius": 0.018}, ("options", "bend_radius")),
                                          ({"dies": [18.0, 0.018]}, ("options", "dies", 1))])
def test_a_bend_radius_far_under_the_sample_spacing_is_refused(options, loc):
    scan = TubeScan(TubeRequest(points=EXAMPLE["points"], options=options))  # 18 mm typed as metres
    with pytest.raises(InputRejected) as exc:
        check_input(scan)
    assert exc.value.errors[0].loc == loc and "spacing" in exc.value.errors[0].msg


def test_a_tolerance_larger_than_the_scan_is_refused():
    scan = TubeScan(TubeRequest(points=EXAMPLE["points"], options={"tolerance": 500.0}))
    with pytest.raises(InputRejected) as exc:
        check_input(scan)
    assert exc.value.errors[0].loc == ("options", "tolerance")


def test_implausible_given_radii_and_tolerances_are_warned_with_their_range():
    model = make_model([[50, 0, 90, 18], [50, 0, 0, 0]], 6.0)
    extent = 120.0
    ok = implausible_against_scan(model, TubeOptions(bend_radius=18.0, tolerance=0.5), "mm", extent)
    assert ok == []
    warned = implausible_against_scan(model, TubeOptions(dies=[18.0, 3.0, 4000.0], tolerance=12.0), "mm", extent)
    assert [w.code for w in warned] == ["implausible_bend_radius", "implausible_bend_radius", "implausible_tolerance"]
    under, over, eps = warned
    assert under.details["field"] == "options.dies[1]" and "under the pipe radius" in under.message
    assert over.details["field"] == "options.dies[2]" and over.details["plausible"] == [6.0, 120.0]
    # a bend whose chord fits in a 120 mm scan on a 4 m die turns at most 2 asin(120 / 8000) = 1.7°
    assert "at most 1.7°" in over.message
    assert eps.details["tolerance"] == 12.0 and "above the pipe radius" in eps.message


def test_a_die_list_with_an_absurd_die_solves_and_warns_naming_it():
    body = {**EXAMPLE, "options": {**EXAMPLE["options"], "dies": [18.0, 5000.0]}}
    scan = TubeScan(TubeRequest.model_validate(body))
    check_input(scan)
    result = solve(scan).result
    warned = [w for w in result.report.warnings if w.code == "implausible_bend_radius"]
    assert [w.details["field"] for w in warned] == ["options.dies[1]"]
    assert result.bend_radius_model.chosen == "given_dies"
    assert [r.bend_radius for r in result.lra[:-1]] == [18.0] * 3


# --- verdicts that tell the truth -------------------------------------------------------------------------------


def test_the_example_fails_its_inspection_and_the_job_says_so(client):
    response = client.post("/v1/tube/jobs", json=EXAMPLE)
    assert response.status_code == 202, response.text
    done = wait_for(client, response.json()["id"], timeout=240)
    assert done["status"] == "succeeded", done
    report = client.get(f"/v1/jobs/{done['id']}/result").json()["report"]
    assert report["status"] == "warning"
    assert report["message"] == "3 bends reconstructed; inspection FAIL: rows 1, 2, 3 (angle)."
    first = report["warnings"][0]
    assert first["code"] == "inspection_failed" and first["details"]["rows"] == [1, 2, 3]
    assert first["details"]["fields"] == ["angle"]
    assert all(f["unit"] == "deg" and abs(f["deviation"]) > f["tolerance"] for f in first["details"]["failed"])


def test_a_nominal_with_another_bend_count_is_not_comparable_naming_both_counts():
    nominal = [{"length": 80, "angle": 90, "bend_radius": 18}, {"length": 45, "rotation": 90, "angle": 45,
                                                                 "bend_radius": 18}, {"length": 70}]
    body = {**EXAMPLE, "options": {"nominal": nominal}}
    scan = TubeScan(TubeRequest.model_validate(body))
    result = solve(scan).result
    ins = result.inspection
    assert ins.verdict == "not_comparable" and not ins.matched and ins.failed_rows == []
    assert (ins.nominal_bends, ins.measured_bends) == (2, 3)
    first = result.report.warnings[0]
    assert first.code == "inspection_not_comparable" and "the nominal has 2 bend(s), the scan 3" in first.message
    assert result.report.status == "warning" and "inspection NOT COMPARABLE" in result.report.message
    # the plots say it too, and read as every plot must
    figs = figures(scan, result)
    for name in ("inspection", "inspection_overlay"):
        check_figure(figs[name])
    texts = [t.get_text() for ax in figs["inspection"].axes for t in ax.texts]
    assert any(t.startswith("not comparable: the nominal has 2 bend(s), the scan 3") for t in texts)
    assert figs["inspection"].axes[0].get_title().startswith("Inspection NOT COMPARABLE")


def test_extent_is_the_bounding_box_diagonal():
    assert scan_extent(np.array([[0, 0, 0], [3, 4, 12.0]])) == pytest.approx(13.0)
