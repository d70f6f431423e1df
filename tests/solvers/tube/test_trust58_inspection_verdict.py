"""A tube scan inspected against its nominal says its verdict on every surface: a part out of tolerance is FAIL
and a part whose end straight the scan stops short of is NOT DETERMINED in the result, the report's verdict and
summary, the verdict the job's summary and the dashboard read (``verdicts_of`` of the report's warnings), the
CLI's exit code and the corrections table; only a part within every tolerance is a pass (no verdict, exit 0). The
surfaces are tested with a stand-in kind elsewhere; this is the tube solver's own report read by them. The
inspection plot drew an end point the samples stop short of as a blue (within tolerance) diamond: it is grey,
'not determined', now."""

from __future__ import annotations

import csv
import io
import json

import numpy as np
import pytest

from plantsolve import cli
from plantsolve.app.verdicts import report_warnings
from plantsolve.schemas.common import verdicts_of
from plantsolve.schemas.tube import TubeRequest
from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.tube.artifacts import VERDICT_COLOURS, corrections_csv, inspection_figure
from plantsolve.solvers.tube.model import build_spine
from plantsolve.solvers.tube.solve import solve
from plantsolve.solvers.tube.synthetic import make_model, surface_samples
from plantsolve.solvers.tube.upload import parse_upload

ROWS = [[80.0, 0.0, 90.0, 18.0], [45.0, 90.0, 45.0, 18.0], [30.0, -45.0, 30.0, 18.0], [70.0, 0.0, 0.0, 0.0]]
NOMINAL_CSV = "row,length_mm,rotation_deg,angle_deg,bend_radius_mm\n" + "".join(
    f"{k + 1},{r[0]:g},{r[1]:g},{r[2]:g},{r[3]:g}\n" for k, r in enumerate(ROWS))


def _scan(cut_end_at: float | None = None) -> str:
    """An XYZ scan of the nominal tube (6 mm radius, 0.01 mm noise); its last straight's samples beyond
    ``cut_end_at`` mm of it dropped (the scanner stopped short)."""
    model = make_model(ROWS, 6.0)
    pts = surface_samples(model, 2500, np.random.default_rng(5), noise=0.01)
    if cut_end_at is not None:
        spine = build_spine(model)
        pts = pts[(pts - spine.start[-1]) @ spine.tangent[-1] < cut_end_at]
    return "".join(f"{x:.4f} {y:.4f} {z:.4f}\n" for x, y, z in pts)


CASES = {  # name: (scan, nominal CSV, verdict, report verdict label, warning code)
    "pass": (_scan(), NOMINAL_CSV, "pass", None, None),
    "fail": (_scan(), NOMINAL_CSV.replace("2,45,90,45,18", "2,45,90,48,18"), "fail", "FAIL", "inspection_failed"),
    "not determined": (_scan(cut_end_at=30.0), NOMINAL_CSV, "not_determined", "NOT DETERMINED",
                       "inspection_not_determined"),
}


@pytest.fixture(scope="module")
def solved() -> dict:
    return {name: solve(parse_upload(StoredInput.from_bytes("scan.xyz", scan.encode()), {"nominal_csv": nominal})).result
            for name, (scan, nominal, *_) in CASES.items()}


@pytest.mark.parametrize("name", CASES)
def test_the_inspections_verdict_is_said_on_every_surface(solved, name):
    _, _, verdict, label, code = CASES[name]
    result = solved[name]
    report = json.loads(result.model_dump_json())["report"]  # as the job stores it
    assert result.inspection.verdict == verdict
    found = verdicts_of(report_warnings(report))  # what the job's summary, the list and the job page show
    if label is None:  # a pass: no verdict anywhere, exit 0
        assert report["verdict"] is None and report["status"] == "ok" and found == []
        assert report["message"].endswith("inspection PASS.")
        assert cli.finished_line("j", report, 0) == 0
        return
    assert report["verdict"]["label"] == label and report["verdict"]["code"] == code
    assert found[0].label == label and report["status"] == "warning"
    assert f"inspection {label}" in report["message"]
    assert cli.finished_line("j", report, len(report["warnings"])) == cli.EXIT_VERDICT == 3
    table = list(csv.DictReader(io.StringIO(corrections_csv(result).decode())))
    assert {t["part_verdict"] for t in table} == {verdict}
    if verdict == "not_determined":
        assert table[-1]["status"] == "not determined" and table[-1]["undetermined_fields"] == "length"
    else:
        assert [t["status"] for t in table] == ["pass", "fail", "pass", "pass"]


def test_an_end_point_the_samples_stop_short_of_is_drawn_not_determined(solved):
    result = solved["not determined"]
    end = result.inspection.end_points[1]
    assert end.ok is None and not end.determined  # no verdict: neither a pass nor a failure
    request = TubeRequest.model_validate({"points": [[0.0, 0.0, 0.0]] * 4, "options": {"nominal_csv": NOMINAL_CSV}})
    fig = inspection_figure(request, result)
    diamonds = [line for line in fig.axes[0].get_lines() if line.get_marker() == "D"]
    assert [d.get_color() for d in diamonds] == [VERDICT_COLOURS["pass"], VERDICT_COLOURS["not determined"]]


FIELDS = ("length", "rotation", "angle", "bend_radius")


def _oks(inspection: dict) -> tuple[list, list, dict]:
    """Each row's ``ok``, each end point's, and each field's (row, field) -> ok, read from the stored JSON."""
    fields = {(r["row"], f): r[f]["ok"] for r in inspection["rows"] for f in FIELDS if r[f] is not None}
    return [r["ok"] for r in inspection["rows"]], [e["ok"] for e in inspection["end_points"]], fields


def test_ok_is_null_where_the_scan_does_not_determine_and_a_verdict_elsewhere(solved):
    """``ok`` said true on a field, row or end point the samples do not determine (a client reading it saw a pass
    where nothing was measured): it is null there now, true only on what is determined and within tolerance, false
    on what is determined and out of it; the corrections table writes 'not determined', never 'True'."""
    stored = {name: json.loads(result.model_dump_json())["inspection"] for name, result in solved.items()}
    rows, ends, fields = _oks(stored["pass"])
    assert rows == [True] * 4 and ends == [True, True] and set(fields.values()) == {True}

    rows, ends, fields = _oks(stored["fail"])  # row 2 bent 45° against a nominal 48°, everything else determined
    assert rows == [True, False, True, True] and ends == [True, True]
    assert [k for k, ok in fields.items() if ok is not True] == [(2, "angle")] and fields[2, "angle"] is False

    rows, ends, fields = _oks(stored["not determined"])  # the scan stops 40 mm short of the last straight's end
    assert ends == [True, None] and rows == [True, True, True, None]
    assert [k for k, ok in fields.items() if ok is not True] == [(4, "length")] and fields[4, "length"] is None
    assert stored["not determined"]["verdict"] == "not_determined"
    text = corrections_csv(solved["not determined"]).decode()
    last = list(csv.DictReader(io.StringIO(text)))[-1]
    assert last["status"] == "not determined" and last["end_points_not_determined"] == "end"
    assert last["end_points_failed"] == "" and "True" not in text and "None" not in text
