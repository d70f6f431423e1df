"""Files as real exporters write them (``pcf_exports.py``): accepted item by item, aligned within the
tolerance their tool works to, written back faithfully (same connections on re-reading, gaps within
tolerance, unmoved items byte for byte), by both methods."""

import re
from pathlib import Path

import numpy as np
import pytest

from plantsolve.schemas.alignment import AlignmentRequest
from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.alignment.artifacts import render_artifacts
from plantsolve.solvers.alignment.solve import solve
from plantsolve.solvers.alignment.upload import parse_upload
from plantsolve.solvers.alignment.model import build_model, connection_errors
from plantsolve.solvers.alignment.pcf import read_document
from plantsolve.solvers.alignment.synthetic import grid_network

from pcf_exports import FIXTURES

DATA = Path(__file__).parent / "data"
METHODS = ["direct", "dual_quaternion"]
# every PCF fixture, the tie-ins its user would fix, and the cuts it needs
FILES = [
    ("e3d_return_bends.pcf", ["1"], 0),
    ("revit_caps_materials.pcf", [], 0),
    ("tree_250m.pcf", [], 0),
    ("flange_gasket_gaps.pcf", ["FLA0"], 0),
    ("plant3d_cw_line.pcf", ["FLANGE-1", "FLANGE-33"], 0),
    ("sp3d_inch_tabs.pcf", ["FLANGE-1", "FLANGE-18", "FLANGE-19"], 0),
    ("e3d_plant_conflict.pcf", ["1", "15"], 0),
    ("converter_handwheels.pcf", ["1"], 0),
]


@pytest.mark.parametrize("name", sorted(FIXTURES))
def test_fixture_files_are_what_the_builders_write(name):
    assert (DATA / name).read_bytes() == FIXTURES[name]().encode()


def _run(name, fixed, method, **options):
    raw = (DATA / name).read_bytes()
    req = parse_upload(StoredInput.from_bytes(name, raw), {"fixed_components": fixed, "method": method, **options})
    solved = solve(req)
    res = solved.result
    out = render_artifacts(req, solved)[0].data
    return raw, req, res, out


@pytest.fixture(scope="module", params=[(f, m) for f in FILES for m in METHODS],
                ids=[f"{f[0]}-{m}" for f in FILES for m in METHODS])
def aligned(request):
    (name, fixed, cuts), method = request.param
    return (name, cuts) + _run(name, fixed, method)


# the paper's alternating iteration stalls short of these tolerances here (see the bench table); it must say
# so truthfully and keep what it did not close listed
SLOW_FOR_THE_PAPER_METHOD = {"plant3d_cw_line.pcf", "sp3d_inch_tabs.pcf", "e3d_plant_conflict.pcf"}


def test_accepted_and_aligned_within_the_tool_tolerance(aligned):
    name, cuts, raw, req, res, out = aligned
    method = req.options.method
    assert len(res.cut_connections) == cuts
    assert res.report.details["tolerance_profile"] in ("aveva_e3d", "printed_precision", "autocad_plant3d")
    assert not [w for w in res.report.warnings if w.code in ("pcf_items_held", "pcf_items_unread")]
    if method == "direct" or name not in SLOW_FOR_THE_PAPER_METHOD:
        assert res.converged, res.report.message
        assert "cap" not in res.report.details["stop_reason"]
        assert not [w for w in res.report.warnings if w.code in ("not_converged", "connections_opened")]
    else:
        assert res.converged or "stalled" in res.report.message or "iteration cap (4000)" in res.report.message
        if not res.converged:
            assert any(w.code == "not_converged" for w in res.report.warnings)


def test_written_back_faithfully(aligned):
    """align -> write -> read: the same connections, gaps and angles within tolerance, and the lines of
    every item that did not move byte for byte."""
    name, cuts, raw, req, res, out = aligned
    text_in, text_out = raw.decode(), out.decode()
    again = parse_upload(StoredInput.from_bytes(name, out), req.options.model_dump())
    key = lambda c: tuple(sorted((tuple(c.from_), tuple(c.to))))
    assert sorted(map(key, again.connections)) == sorted(map(key, req.connections))
    model = build_model(again)
    gap, ang = connection_errors(model, model.P0, model.D0)
    closed = np.array([r.position_error <= res.report.details["position_tolerance"] for r in res.connections])
    assert np.all(gap[closed] <= model.pos_tol) and np.all(ang[closed] <= model.ang_tol[closed])
    lines_in, lines_out = re.split(r"(?<=\n)", text_in), re.split(r"(?<=\n)", text_out)
    assert len(lines_in) == len(lines_out)
    doc = read_document(text_in)
    moved = {c.id for c in res.components if c.displacement > doc.quantum / 2}
    solved = {c.id for c in res.components}
    for item in doc.items:
        if item.id not in solved:  # welds and point gaskets go where their connection went
            continue
        block = range(item.line, (doc.items[item.ordinal].line if item.ordinal < len(doc.items) else len(lines_in)))
        if item.id not in moved and item.point_lines and all(
                r not in moved for r in _neighbours(req, item.id)) or item.id in req.options.fixed_components:
            assert [lines_out[i] for i in block] == [lines_in[i] for i in block], item.id
    for a, b in zip(lines_in, lines_out):  # only coordinates ever change
        if a != b:
            assert a.split()[0] == b.split()[0] and a.split()[4:] == b.split()[4:]


def _neighbours(req, cid):
    out = set()
    for c in req.connections:
        if c.from_[0] == cid:
            out.add(c.to[0])
        if c.to[0] == cid:
            out.add(c.from_[0])
    return out


def test_aligning_the_aligned_file_moves_nothing(aligned):
    name, cuts, raw, req, res, out = aligned
    if not res.converged:
        pytest.skip("not converged: there is more to move")
    again = parse_upload(StoredInput.from_bytes(name, out), req.options.model_dump())
    solved = solve(again)
    res2 = solved.result
    assert res2.iterations == 0 and all(c.displacement == 0.0 for c in res2.components)
    assert render_artifacts(again, solved)[0].data == out


def test_e3d_return_bends_misc_component_and_olet():
    raw, req, res, out = _run("e3d_return_bends.pcf", ["1"], "direct")
    comps = {c.id: c for c in req.components}
    assert list(comps)[:3] == ["1", "2", "3"]  # COMPONENT-IDENTIFIER, not file positions
    items = res.report.details["pcf_items"]
    assert items["id_source"] == {"COMPONENT-IDENTIFIER": 16, "position": 1}  # + the end-connection marker
    assert {i["position_id"]: i["id"] for i in items["items"]}["BEND-4"] == "3"
    assert res.report.details["tolerance_profile"] == "aveva_e3d"  # from its =16384/... references
    bends = [c for c in req.components if c.type == "bend"]
    assert len(bends) == 3
    for b in bends:  # 180 degrees: both ports parallel and normal to the chord
        (p0, p1), (d0, d1) = ([np.array(getattr(p, k)) for p in b.ports] for k in ("position", "direction"))
        assert np.degrees(np.arccos(np.clip(d0 @ d1, -1, 1))) < 0.2
        assert abs(d0 @ (p1 - p0)) / np.linalg.norm(p1 - p0) < 2e-3
    misc = next(c for c in req.components if c.id == "7")
    assert misc.type == "other" and len(misc.ports) == 2
    olet = next(c for c in req.components if c.type == "olet")
    assert olet.ports[0].direction == pytest.approx([0.0, 0.0, 1.0], abs=1e-3)  # away from its pipe's axis
    details = res.report.details["pcf_directions_from_neighbours"]["items"]
    assert {d["id"] for d in details} >= {"3", "5", olet.id}
    moved = max(c.displacement for c in res.components if c.id != "1")
    assert 1.0 < moved < 10.0  # the drifted items were put back, by millimetres


def test_without_tie_ins_the_nozzle_at_the_end_connection_is_held_and_named():
    raw, req, res, out = _run("e3d_return_bends.pcf", [], "direct")
    anchors = next(w for w in res.report.warnings if w.code == "anchored").details["anchors"]
    assert {"id": "1", "network_size": 13, "why": "at an end connection"} in anchors
    assert next(c for c in res.components if c.id == "1").displacement == 0.0
    assert out.split(b"\n")[9:13] == raw.split(b"\n")[9:13]  # the marker stays where the nozzle is


def test_revit_two_point_caps_materials_and_dates():
    raw, req, res, out = _run("revit_caps_materials.pcf", [], "direct")
    assert not [w for w in res.report.warnings if w.code == "pcf_unknown_keyword"]
    caps = [c for c in req.components if c.type == "cap"]
    assert sorted(len(c.ports) for c in caps) == [1, 2]  # one with the cap's length, one with coincident points
    assert all(c.id.startswith("4123") for c in req.components)  # the element ids
    assert res.report.details["tolerance_profile"] == "printed_precision"
    assert res.report.details["position_tolerance"] == pytest.approx(2 * np.sqrt(3) * 0.5e-4)
    anchored = next(w for w in res.report.warnings if w.code == "anchored").details["anchors"]
    assert anchored == [{"id": "412300", "network_size": 9, "why": "end flange (open port)"}]
    assert next(c for c in res.components if c.id == "412300").displacement == 0.0
    assert out.count(b"\r\n") == raw.count(b"\r\n") and b"\n" not in out.replace(b"\r\n", b"")


def test_a_tree_with_only_rounding_differences_is_left_alone():
    raw, req, res, out = _run("tree_250m.pcf", [], "direct")
    d = res.report.details
    assert 0.0 < d["initial_max_angle_deg"] < 0.005 and d["initial_max_gap"] < d["position_tolerance"]
    assert d["stop_reason"] == "input already within tolerance"
    assert all(c.displacement == 0.0 for c in res.components) and out == raw
    assert d["within_rounding_at_start"] == len(req.connections)
    # the old default (exact, 1e-10) would have moved the line to close rounding noise
    tight = solve(parse_upload(StoredInput.from_bytes("tree.pcf", raw), {"tolerance_profile": "custom"})).result
    assert max(c.displacement for c in tight.components) > 1e-3


def test_flange_faces_a_gasket_apart_keep_their_gap():
    raw, req, res, out = _run("flange_gasket_gaps.pcf", ["FLA0"], "direct")
    gaps = next(w for w in res.report.warnings if w.code == "pcf_gasket_gaps").details["gaps"]
    assert [g["gap"] for g in gaps] == pytest.approx([3.0, 3.0], abs=2e-3)
    ports = {c.id: c.ports for c in res.components}
    for g in gaps:  # still 3 mm apart after alignment
        a = [np.array(p.position) for p in ports[g["from"]]]
        b = [np.array(p.position) for p in ports[g["to"]]]
        assert min(np.linalg.norm(x - y) for x in a for y in b) == pytest.approx(3.0, abs=2e-3)
    # the 2 mm defect in the first run is what moved; flanges and valve stayed
    moved = {c.id for c in res.components if c.displacement > 1e-3}
    assert moved and all(m.startswith(("PIP", "ELB")) for m in moved)
    assert res.max_position_error == 0.0


def test_return_bend_alone_is_held_with_its_reason():
    text = "UNITS-CO-ORDS MM\nBEND\n    END-POINT 0 0 0 100\n    END-POINT 0 400 0 100\n    CENTRE-POINT 0 200 0\n" \
           "    ANGLE 18000\nPIPE\n    END-POINT 5000 0 0 100\n    END-POINT 6000 0 0 100\n"
    res = solve(parse_upload(StoredInput.from_bytes("x.pcf", text.encode()), None)).result
    held = next(w for w in res.report.warnings if w.code == "pcf_items_held").details["items"]
    assert held[0]["id"] == "BEND-1" and "direction" in held[0]["reason"]


@pytest.mark.parametrize("method", METHODS)
def test_a_closed_loop_with_one_drifted_pipe_keeps_its_closed_connections(method):
    base = grid_network(3, 3, pipe_noise=(0.0, 0.0), fitting_noise=(0.0, 0.0), tie_ins=((0, 0),),
                        options={"method": method, "tolerance_profile": "custom", "position_tolerance": 1e-6,
                                 "angle_tolerance": 1e-6})
    comps = [c.model_copy(deep=True) for c in base.components]
    pipe = next(c for c in comps if c.kind == "pipe" and not c.fixed)
    for p in pipe.ports:
        p.position = [p.position[0] + 1.5, p.position[1] - 1.0, p.position[2]]
    req = base.model_copy(update={"components": comps})
    res = solve(req).result
    assert res.converged and not res.cut_connections
    assert not [w for w in res.report.warnings if w.code == "connections_opened"]


def test_dual_quaternion_never_cuts_a_tree():
    req = grid_network(1, 4, tie_ins=((0, 0),), seed=4, options={
        "method": "dual_quaternion", "explosion_factor": 1.2, "step_limit": 400.0, "tolerance_profile": "custom"})
    res = solve(req).result
    assert not res.cut_connections
    stop = res.report.details["stop_reason"]
    assert res.converged == stop.startswith("all connections within tolerance")


def test_json_requests_keep_exact_tolerances_and_say_so():
    req = AlignmentRequest.model_validate(grid_network(2, 2, tie_ins=((0, 0),)).model_dump(by_alias=True))
    d = solve(req).result.report.details
    assert d["tolerance_profile"] == "custom" and d["position_tolerance"] == 1e-10
    assert "JSON" in d["tolerance_reason"]
