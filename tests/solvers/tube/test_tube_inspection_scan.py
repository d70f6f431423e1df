"""Known answer through the whole pipeline: a 'made' tube simulated from a nominal with known errors (each bend
1.5° short, row 2's rotation 2° off, row 3's straight 3 mm long), scanned by the synthetic scanner and solved
with the nominal, returns those errors within the reconstruction's stated accuracy (its sigmas), fails the right
rows, and corrects by the negated errors (springback 1.5°); its artifacts carry the same numbers."""

from __future__ import annotations

import csv
import io

import numpy as np
import pytest

from plantsolve.schemas.tube import TubeOptions, TubeRequest
from plantsolve.solvers.tube.scan import TubeScan
from plantsolve.solvers.tube.solve import solve
from plantsolve.solvers.tube.artifacts import (
    corrections_csv,
    figures,
    lra_csv,
    model_from_result,
    render_artifacts,
    xyz_clr_csv,
)
from plantsolve.solvers.tube.inspection import inspect_request
from plantsolve.solvers.tube.nominal_files import read_nominal_csv
from plantsolve.solvers.tube.synthetic import make_model, surface_samples
from tests.support.plots import check_figure

NOMINAL = [[50, 0, 90, 16], [30, 60, 45, 16], [40, -90, 60, 16], [50, 0, 0, 0]]
ERRORS = np.array([[0, 0, -1.5], [0, 2, -1.5], [3, 0, -1.5], [0, 0, 0]])  # length, rotation, angle per row
FLOOR = np.array([0.03, 0.03, 0.03])  # mm, deg, deg: below the sigmas' own rounding


@pytest.fixture(scope="module")
def solved():
    made = np.array(NOMINAL, float)
    made[:, :3] += ERRORS
    model = make_model(made, 4.0, start=(10.0, -5.0, 3.0))
    pts = surface_samples(model, 5000, np.random.default_rng(0), noise=0.02)
    scan = TubeScan(TubeRequest(points=pts.tolist(), options={
        "nominal": [{"length": a, "rotation": b, "angle": c, "bend_radius": d} for a, b, c, d in NOMINAL]}))
    return scan, solve(scan)


def _within_sigmas(result, got):
    """|got − known| ≤ 4 σ (+ a floor) per row and field; the end straights' length has no sigma (where the
    samples end): 0.25 mm."""
    ins = result.inspection
    assert not ins.reversed  # the made tube starts where the nominal does: sigmas row by row
    for row, g, want in zip(result.lra, got, ERRORS):
        sig = np.array([row.sigma_length if row.sigma_length is not None else 0.25 / 4,
                        row.sigma_rotation or 0.0, row.sigma_angle or 0.0])
        assert np.all(np.abs(np.asarray(g) - want) <= 4 * sig + FLOOR), (g, want, sig)


def test_scan_deviations_are_the_known_errors(solved):
    result = solved[1].result
    got = [[r.length.deviation, r.rotation.deviation if r.rotation else 0.0, r.angle.deviation if r.angle else 0.0]
           for r in result.inspection.rows]
    _within_sigmas(result, got)


def test_scan_verdict_fails_the_right_rows(solved):
    ins = solved[1].result.inspection
    assert ins.verdict == "fail" and ins.failed_rows == [1, 2, 3]
    assert [r.failed for r in ins.rows] == [["angle"], ["rotation", "angle"], ["length", "angle"], []]


def test_scan_corrections_are_the_negated_errors(solved):
    result = solved[1].result
    c = result.inspection.corrections
    _within_sigmas(result, [[-x.delta_length, -x.delta_rotation, -x.delta_angle] for x in c])
    assert [x.springback for x in c[:3]] == pytest.approx([1.5] * 3, abs=0.1)


def test_corrections_csv_states_units_and_the_corrections(solved):
    result = solved[1].result
    table = list(csv.DictReader(io.StringIO(corrections_csv(result).decode())))
    assert {"nominal_length [mm]", "deviation_angle [deg]", "springback [deg]", "next_angle [deg]", "next_clr [mm]",
            "status", "failed_fields"} <= set(table[0])
    assert [t["status"] for t in table] == ["fail", "fail", "fail", "pass"]
    assert table[2]["failed_fields"] == "length angle"
    for t, c in zip(table, result.inspection.corrections):
        assert float(t["next_angle [deg]"]) == pytest.approx(c.next.angle, abs=1e-6)
        assert float(t["delta_length [mm]"]) == pytest.approx(c.delta_length, abs=1e-6)


@pytest.mark.slow
def test_inspection_artifacts_are_rendered(solved):
    names = [a.name for a in render_artifacts(*solved)]  # meshes and the deviation cloud: about 2 s
    assert {"corrections.csv", "inspection_overlay.png", "inspection.png"} <= set(names)


def test_overlay_plot_labels_the_rows_out_of_tolerance(solved):
    scan, s = solved
    fig = figures(scan, s.result)["inspection_overlay"]
    check_figure(fig)
    plan, elevation = fig.axes[:2]
    assert plan.get_xlabel() == "1st principal axis of the measured centreline [mm]"
    assert elevation.get_ylabel() == "3rd principal axis [mm]"
    labels = sorted(t.get_text() for t in plan.texts)
    assert [lab.split(":")[0] for lab in labels] == ["row 1", "row 2", "row 3"]
    assert float(labels[2].split("L ")[1].split(",")[0]) == pytest.approx(3.0, abs=0.1)
    assert float(labels[1].split("R ")[1].split(",")[0]) == pytest.approx(2.0, abs=0.1)
    assert [t.get_text() for t in fig.legends[0].get_texts()][:2] == ["nominal (best-fit aligned)", "measured"]
    # both centrelines lie within a few mm of each other: the overlay's curves are the aligned pair
    nom, meas = plan.get_lines()[:2]
    assert np.ptp(nom.get_xdata()) == pytest.approx(np.ptp(meas.get_xdata()), abs=5.0)


def test_own_lra_and_xyz_clr_output_are_accepted_as_nominal(solved):
    _scan, s = solved
    result = s.result
    model = model_from_result(result)
    want = np.array([[r.length, r.rotation, r.angle, r.bend_radius] for r in result.lra])
    for text in (lra_csv(result), xyz_clr_csv(result, model)):
        rows = read_nominal_csv(text.decode()).rows
        np.testing.assert_allclose([[r.length, r.rotation, r.angle, r.bend_radius] for r in rows], want, atol=1e-5)
    # the scan inspected against its own output passes
    ins = inspect_request(model, TubeOptions(nominal_csv=xyz_clr_csv(result, model).decode()), "mm")
    assert ins.verdict == "pass" and ins.nominal_source.startswith("nominal_csv: XYZ-CLR")
