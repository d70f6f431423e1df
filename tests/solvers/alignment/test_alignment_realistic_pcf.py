"""Realistic PCF exports (Plant 3D, SmartPlant, AVEVA E3D style): parse -> align -> write -> parse.

Fixtures in ``data/`` are hand-written like the tools export them: header records, attribute
lines, MATERIALS section, welds and gaskets, olets, supports, CRLF / tabs / lower case, inch
coordinates, plant coordinates near 1e6 mm, gaps of a few mm.
"""

import random
import re
from pathlib import Path

import numpy as np
import pytest

from plantsolve.solvers.alignment.artifacts import render_artifacts
from plantsolve.solvers.alignment.solve import solve
from plantsolve.solvers.alignment.upload import parse_upload
from plantsolve.solvers.alignment.validation import check_input
from plantsolve.solvers.base import InputRejected, SolverError, StoredInput

DATA = Path(__file__).parent / "data"
POINT_WORDS = {"END-POINT", "CENTRE-POINT", "BRANCH1-POINT", "BRANCH2-POINT", "BRANCH3-POINT", "CO-ORDS"}

# fixture, tie-ins, expected number of cuts
CASES = [
    ("plant3d_cw_line.pcf", ["0F1A3C22-1B7E-4A2E-9D0C-11AA00000001", "FLANGE-33"], 0),
    ("sp3d_inch_tabs.pcf", ["F4WN150", "FLANGE-18", "FLANGE-19"], 0),
    ("e3d_plant_conflict.pcf", ["1", "15"], 1),  # with the tight 'custom' profile (see below)
]


def _lines(text):
    return re.split(r"(?<=\n)", text)


def _align(name, fixed, **options):
    raw = (DATA / name).read_bytes()
    req = parse_upload(StoredInput.from_bytes(name.upper(), raw), {"fixed_components": fixed, **options})
    solved = solve(req)
    res = solved.result
    art = {a.name: a for a in render_artifacts(req, solved)}
    return raw.decode(), req, res, art["aligned.pcf"].data.decode()


@pytest.fixture(scope="module", params=CASES, ids=[c[0] for c in CASES])
def aligned(request):
    name, fixed, cuts = request.param
    options = {"tolerance_profile": "custom"} if cuts else {}
    return (name, fixed, cuts) + _align(name, fixed, **options)


def test_closes_with_the_expected_cuts(aligned):
    name, fixed, cuts, src, req, res, out = aligned
    assert len(res.cut_connections) == cuts
    assert res.converged
    assert res.max_position_error == 0.0 and res.max_angle_error == 0.0
    for c in res.connections:
        if not c.cut:
            assert c.position_error == 0.0
    if cuts:
        assert any(w.code == "connections_cut" for w in res.report.warnings)


def test_every_unchanged_line_is_kept_byte_for_byte(aligned):
    name, fixed, cuts, src, req, res, out = aligned
    a, b = _lines(src), _lines(out)
    assert len(a) == len(b)
    for x, y in zip(a, b):
        # line endings (CRLF stays CRLF), indentation, keyword and everything after the coordinates
        assert x[len(x.rstrip("\r\n")):] == y[len(y.rstrip("\r\n")):]
        if x == y:
            continue
        xs, ys = x.split(), y.split()
        assert xs[0].upper() in POINT_WORDS, (x, y)
        assert xs[0] == ys[0] and xs[4:] == ys[4:]
        assert x[: len(x) - len(x.lstrip())] == y[: len(y) - len(y.lstrip())]
    # the MATERIALS section and every non-geometric attribute survive untouched
    assert src[src.index("MATERIALS"):] == out[out.index("MATERIALS"):]
    assert sum(1 for x, y in zip(a, b) if x != y) > 5  # something was actually aligned


def test_tie_in_lines_untouched_and_written_connections_print_identically(aligned):
    name, fixed, cuts, src, req, res, out = aligned
    req2 = parse_upload(StoredInput.from_bytes("again.pcf", out.encode()), {"fixed_components": fixed,
                                                    **({"tolerance_profile": "custom"} if cuts else {})})
    assert [c.id for c in req2.components] == [c.id for c in req.components]
    assert [(c.from_, c.to) for c in req2.connections] == [(c.from_, c.to) for c in req.connections]
    ports = {c.id: c.ports for c in req2.components}
    for c in req.components:
        if c.id in fixed:
            assert [p.position for p in ports[c.id]] == [p.position for p in c.ports]
    tol = res.report.details["position_tolerance"]
    for k, c in enumerate(req2.connections):
        pa, pb = ports[c.from_[0]][c.from_[1]].position, ports[c.to[0]][c.to[1]].position
        if k in res.cut_connections:
            assert np.linalg.norm(np.subtract(pa, pb)) > 1.0
        else:  # printed alike; reading back may restore a catalogue angle by a few ulps
            assert np.linalg.norm(np.subtract(pa, pb)) <= tol
    # aligning the aligned file moves nothing at all
    res2 = solve(req2).result
    assert len(res2.cut_connections) == cuts
    if not cuts:
        assert res2.iterations == 0 and all(c.displacement == 0.0 for c in res2.components)


def test_zero_length_welds_are_connection_points():
    src, req, res, out = _align("plant3d_cw_line.pcf", ["FLANGE-1", "FLANGE-33"])  # positional aliases
    ids = [c.id for c in req.components]
    assert not any(i.startswith("WELD") for i in ids)
    # the flange connects straight to the pipe the weld joined it to
    flange = "0F1A3C22-1B7E-4A2E-9D0C-11AA00000001"
    assert req.options.fixed_components == [flange, "FLANGE-33"]
    assert any(c.from_ == (flange, 1) and c.to == ("PIPE-3", 0) for c in req.connections)
    assert res.report.details["pcf_zero_length_items"] == ["WELD-2"]
    # 3 mm gaskets are real (rigid) parts with two ports
    gaskets = [c for c in req.components if c.id.startswith("GASKET")]
    assert gaskets and all(len(c.ports) == 2 and c.kind == "fitting" for c in gaskets)
    src2, req2, res2, out2 = _align("sp3d_inch_tabs.pcf", ["F4WN150", "FLANGE-18", "FLANGE-19"])
    # the single-ended weld is written exactly where the pipe and the tie-in flange now meet
    w = _lines(src2).index("weld\n") + 1
    flange = next(c for c in res2.components if c.id == "FLANGE-18").ports[0].position
    pipe = next(c for c in res2.components if c.id == "PIPE-16").ports[1].position
    assert pipe == flange
    assert [float(v) for v in _lines(out2)[w].split()[1:4]] == flange
    assert _lines(out2)[w].split()[1:4] == _lines(out2)[w - 2].split()[1:4]  # same printed strings as the pipe end


def test_unknown_keyword_kept_and_warned():
    src, req, res, out = _align("plant3d_cw_line.pcf", ["0F1A3C22-1B7E-4A2E-9D0C-11AA00000001", "FLANGE-33"])
    warn = [w for w in res.report.warnings if w.code == "pcf_unknown_keyword"]
    assert warn and warn[0].details["keywords"] == ["STRAINER-CUSTOM"]
    assert res.report.status == "warning"
    strainer = next(c for c in req.components if c.id == "STR-T-6")  # its ITEM-CODE
    assert strainer.type == "other" and len(strainer.ports) == 2
    assert "MESSAGE-SQUARE\r\n    TEXT SCANNED 2026-11-02\r\n" in out


def test_component_kinds_from_a_plant3d_export():
    src, req, res, out = _align("plant3d_cw_line.pcf", ["0F1A3C22-1B7E-4A2E-9D0C-11AA00000001", "FLANGE-33"])
    kind = {c.id: (c.kind, c.type, len(c.ports)) for c in req.components}
    assert kind["WOL6X2"] == ("fitting", "olet", 1)
    assert kind["CAP4S40"] == ("fitting", "cap", 1)
    assert kind["FLBL2300RF"] == ("fitting", "flange", 1)
    assert kind["VANGBW6"] == ("fitting", "valve", 2)
    assert kind["TEERED6X4"] == ("fitting", "tee", 3)
    assert kind["BND3D6S40"] == ("fitting", "bend", 2)
    assert req.units == "mm"
    tee = next(c for c in req.components if c.id == "TEERED6X4")
    assert tee.radius == pytest.approx(3 * 25.4)  # 6.0000 inch bore, mm coordinates
    # the angle valve keeps its 90 degrees, the 45 degree elbow its 45
    out_ports = {c.id: c.ports for c in res.components}
    for cid, deg in (("VANGBW6", 90.0), ("ELL45LR6S40", 45.0), ("BND3D6S40", 45.0)):
        d0, d1 = (np.array(p.direction) for p in out_ports[cid])
        assert np.degrees(np.arccos(np.clip(-d0 @ d1, -1, 1))) == pytest.approx(deg, abs=0.01)
    # SPINDLE-DIRECTION UP becomes the valve's up vector, and the stem stays up
    valve = next(c for c in req.components if c.id == "VGAFL4300")
    assert valve.up == [0.0, 0.0, 1.0]
    assert next(c for c in res.components if c.id == "VGAFL4300").up[2] > 0.9999
    assert next(c for c in req.components if c.id == "VANGBW6").up is None  # no spindle line
    # single-ended items face their partner
    cap = out_ports["CAP4S40"][0].direction
    pipe = out_ports["PIPE-15"][1].direction
    assert np.allclose(cap, -np.array(pipe), atol=1e-12)


def test_support_follows_its_pipe_sideways_only():
    src, req, res, out = _align("plant3d_cw_line.pcf", ["0F1A3C22-1B7E-4A2E-9D0C-11AA00000001", "FLANGE-33"])
    line = next(ln for ln in _lines(out) if ln.strip().startswith("CO-ORDS"))
    s_new = np.array([float(v) for v in line.split()[1:4]])
    s_old = np.array([13000.0, -3500.0, 2915.0])
    before = next(c for c in req.components if c.id == "PIPE-5")
    after = next(c for c in res.components if c.id == "PIPE-5")

    def offset(comp, s):
        a, b = (np.array(p.position) for p in comp.ports)
        u = (b - a) / np.linalg.norm(b - a)
        return (s - a) - np.dot(s - a, u) * u, u

    off_old, _ = offset(before, s_old)
    off_new, u_new = offset(after, s_new)
    # printed with the file's 4 decimals: within half a last digit per coordinate
    assert np.linalg.norm(off_new) == pytest.approx(np.linalg.norm(off_old), abs=1e-4)  # still under the pipe
    assert np.dot(s_new - s_old, u_new) == pytest.approx(0.0, abs=1e-4)  # not slid along it
    assert np.linalg.norm(s_new - s_old) > 0.05  # but it did follow the pipe


def test_eccentric_reducer_takes_the_pipe_axis_not_the_offset_end_points():
    src, req, res, out = _align("sp3d_inch_tabs.pcf", ["F4WN150", "FLANGE-18", "FLANGE-19"])
    red = next(c for c in req.components if c.id == "REDUCER-ECCENTRIC-7")
    d0, d1 = (np.array(p.direction) for p in red.ports)
    assert d0 @ d1 == pytest.approx(-1.0, abs=1e-12)
    # the end points are 0.5 in apart sideways (flat side down) but the axis is the pipes' (-y)
    assert np.degrees(np.arccos(d1 @ [0.0, -1.0, 0.0])) < 0.2
    # so the 3 inch leg stays level instead of being tilted by 5.7 degrees
    leg = next(c for c in res.components if c.id == "PIPE-10")
    assert leg.ports[1].position[2] == pytest.approx(11.5, abs=0.02)
    assert req.units == "in" and red.radius == pytest.approx(2.0)


def test_inconsistent_tie_ins_cut_inside_the_straight_run():
    # the E3D profile (0.01 rad) accepts the 0.19 degree tilt the 10 mm offset needs; a tight profile cuts
    _, req, res, _ = _align("e3d_plant_conflict.pcf", ["1", "15"])
    assert res.report.details["tolerance_profile"] == "aveva_e3d" and not res.cut_connections
    src, req, res, out = _align("e3d_plant_conflict.pcf", ["1", "15"], tolerance_profile="custom")
    (k,) = res.cut_connections
    cut = res.report.warnings[0].details["cuts"][0]
    assert cut["reason"] == "conflict"
    # the two nozzles are 10 mm apart sideways: that is what is left open
    assert res.connections[k].position_error == pytest.approx(10.0, abs=0.5)
    straight = {"1", "2", "3", "8", "9", "10", "11", "12",
                "13", "14", "15"}  # not the branch up to the cap
    c = req.connections[k]
    assert c.from_[0] in straight and c.to[0] in straight


def test_crlf_only_and_lone_cr_files_keep_their_endings():
    text = (DATA / "sp3d_inch_tabs.pcf").read_text()
    for eol in ("\r\n", "\r"):
        body = text.replace("\n", eol)
        req = parse_upload(StoredInput.from_bytes("x.pcf", body.encode()), {"fixed_components": ["F4WN150"]})
        solved = solve(req)
        out = render_artifacts(req, solved)[0].data.decode()
        assert out.count(eol) == body.count(eol)
        assert "\n" not in out.replace("\r\n", "") if eol == "\r\n" else "\n" not in out


@pytest.mark.parametrize("text, why", [
    ("", "no PCF components"),
    ("ISOGEN-FILES ISOGEN.FLS\nUNITS-CO-ORDS MM\nMATERIALS\nITEM-CODE X\n    DESCRIPTION Y\n", "no PCF components"),
    ("UNITS-CO-ORDS FURLONG\nPIPE\n    END-POINT 0 0 0 100\n    END-POINT 1 0 0 100\n", "UNITS-CO-ORDS"),
    ("PIPE\n    END-POINT 0 0 zero 100\n    END-POINT 1 0 nan 100\n", "cannot read the coordinates"),
    ("WELD\n    END-POINT 0 0 0 100\n    END-POINT 0 0 0 100\n", "no PCF components"),
])
def test_a_file_with_nothing_usable_is_rejected_on_the_file(text, why):
    with pytest.raises(InputRejected) as e:
        parse_upload(StoredInput.from_bytes("bad.pcf", text.encode()), None)
    assert e.value.errors[0].loc == ("file",)
    assert why in e.value.errors[0].msg


GOOD = "PIPE\n    END-POINT 0 0 0 100\n    END-POINT 1000 0 0 100\n"


@pytest.mark.parametrize("item, code, reason", [
    ("PIPE\n    END-POINT 1000 0 0 100\n", "pcf_items_held", "two END-POINT"),
    ("PIPE\n    END-POINT 1000 0 0 100\n    END-POINT 1000 0 zero 100\n", "pcf_items_held", "cannot read"),
    ("PIPE\n    END-POINT 1000 0 0 100\n    END-POINT 1000 nan 0 100\n", "pcf_items_held", "non-finite"),
    ("CAP\n    END-POINT 5000 0 0 100\n", "pcf_items_held", "direction"),
    ("OLET\n    BRANCH1-POINT 9000 0 50 50\n", "pcf_items_held", "direction"),
    ("OLET\n    CENTRE-POINT 9000 0 50\n    BRANCH1-POINT 9000 0 50 50\n", "pcf_items_held", "direction"),
    ("VALVE\n    END-POINT 0 0 abc 100\n", "pcf_items_unread", "cannot read"),
])
def test_an_item_that_cannot_be_read_is_kept_held_and_reported(item, code, reason):
    """One bad item never refuses the file: it is kept verbatim, held fixed (or left out without a readable
    point) and listed with its line and reason; the rest is aligned."""
    text = "UNITS-CO-ORDS MM\n" + GOOD + item
    req = parse_upload(StoredInput.from_bytes("x.pcf", text.encode()), None)
    solved = solve(req)
    res = solved.result
    note = next(w for w in res.report.warnings if w.code == code)
    (entry,) = note.details["items"]
    assert reason in entry["reason"] and entry["line"] == 5
    out = render_artifacts(req, solved)[0].data.decode()
    assert out.endswith(item)  # written back exactly as read
    if code == "pcf_items_held":
        held = next(c for c in req.components if c.id == entry["id"])
        assert held.fixed and held.type == "other"


def test_mangled_exports_never_crash():
    """Lines dropped, duplicated, garbled, lower-cased or re-indented: only InputRejected/SolverError."""
    rnd = random.Random(7)
    files = sorted(DATA.glob("*.pcf"))
    for _ in range(40):
        lines = _lines(rnd.choice(files).read_text())
        for _ in range(rnd.randint(1, 4)):
            i = rnd.randrange(len(lines))
            op = rnd.random()
            if op < 0.3:
                del lines[i]
            elif op < 0.5:
                lines.insert(i, lines[rnd.randrange(len(lines))])
            elif op < 0.7:
                parts = lines[i].split(" ")
                j = rnd.randrange(len(parts))
                parts[j] = rnd.choice(["", "nan", "1e400", "-0", "abc", "0", "1e6", "PIPE"])
                lines[i] = " ".join(parts)
            elif op < 0.85:
                lines[i] = lines[i].lower()
            else:
                lines[i] = lines[i].replace("    ", "\t")
        try:
            req = parse_upload(StoredInput.from_bytes("f.pcf", "".join(lines).encode()), None)
            check_input(req)  # as the job domain does at submission
            solved = solve(req)
            render_artifacts(req, solved)
        except (InputRejected, SolverError):
            pass


@pytest.mark.parametrize("encoding, bom", [("cp1252", b""), ("utf-8", b"\xef\xbb\xbf"), ("utf-8", b"")])
def test_aligned_pcf_keeps_the_file_encoding_byte_for_byte(encoding, bom):
    text = (DATA / "e3d_plant_conflict.pcf").read_text().replace(
        "GATE VALVE 150 CL300 RF", "GATE VALVE Ø150 CL300 RF 20°C")
    raw = bom + text.encode(encoding)
    req = parse_upload(StoredInput.from_bytes("x.pcf", raw), {"fixed_components": ["1", "15"]})
    from plantsolve.schemas.alignment import AlignmentRequest

    req = AlignmentRequest.model_validate_json(req.model_dump_json(by_alias=True))  # as the job queue stores it
    art = render_artifacts(req, solve(req))[0]
    assert art.data.startswith(bom) and (bom or not art.data.startswith(b"\xef\xbb\xbf"))
    out_lines, in_lines = art.data.split(b"\n"), raw.split(b"\n")
    assert len(out_lines) == len(in_lines)
    changed = [(a, b) for a, b in zip(in_lines, out_lines) if a != b]
    assert changed and all(a.split()[0] in (b"END-POINT", b"CENTRE-POINT", b"BRANCH1-POINT") for a, _ in changed)
    assert "GATE VALVE Ø150 CL300 RF 20°C".encode(encoding) in art.data
    assert ("cp1252" if encoding == "cp1252" else "utf-8") in art.media_type


def test_item_beyond_the_connection_tolerance_is_reported_and_option_widens_it():
    text = (DATA / "plant3d_cw_line.pcf").read_text()
    # the cap sits 40 mm off the 4 inch pipe end: beyond half its radius (25.4 mm)
    moved = text.replace("END-POINT 15001.0000 -2000.0000 3000.0000 4.0000 BW", "END-POINT 15040.0000 -2000.0000 3000.0000 4.0000 BW")
    # a lone cap has no direction to take: kept, held where it is, and reported
    res = solve(parse_upload(StoredInput.from_bytes("x.pcf", moved.encode()), None)).result
    held = next(w for w in res.report.warnings if w.code == "pcf_items_held").details["items"]
    assert [h["id"] for h in held] == ["CAP4S40"] and "direction" in held[0]["reason"]
    # a lone two-ended item is aligned without it and reported
    moved = text.replace("END-POINT 14441.0000 -2000.5000 3000.0000 4.0000 BW", "END-POINT 14480.0000 -2000.5000 3000.0000 4.0000 BW")
    req = parse_upload(StoredInput.from_bytes("x.pcf", moved.encode()), {"fixed_components": ["0F1A3C22-1B7E-4A2E-9D0C-11AA00000001"]})
    res = solve(req).result
    assert not [w for w in res.report.warnings if w.code == "pcf_unconnected_items"]  # pipe still holds the cap
    near = [w for w in res.report.warnings if w.code == "pcf_near_miss"]
    assert near and near[0].details["pairs"][0]["from"] == ["FLANGE-14", 1]
    assert near[0].details["pairs"][0]["to"] == ["PIPE-15", 0]
    assert near[0].details["pairs"][0]["distance"] == pytest.approx(40.3, abs=0.01)
    assert not any(c.from_[0] == "FLANGE-14" and c.to[0] == "PIPE-15" for c in req.connections)
    req = parse_upload(StoredInput.from_bytes("x.pcf", moved.encode()), {"fixed_components": ["0F1A3C22-1B7E-4A2E-9D0C-11AA00000001"], "connection_tolerance": 45.0})
    assert any(c.from_ == ("FLANGE-14", 1) and c.to == ("PIPE-15", 0) for c in req.connections)
    res = solve(req).result
    assert res.converged and not res.cut_connections

    stray = text.replace("MATERIALS\r\n", "INSTRUMENT\r\n    END-POINT 20000.0 0.0 0.0 2.0000\r\n"
                         "    END-POINT 20100.0 0.0 0.0 2.0000\r\nMATERIALS\r\n") if "\r\n" in text else text.replace(
        "MATERIALS\n", "INSTRUMENT\n    END-POINT 20000.0 0.0 0.0 2.0000\n    END-POINT 20100.0 0.0 0.0 2.0000\nMATERIALS\n")
    res = solve(parse_upload(StoredInput.from_bytes("x.pcf", stray.encode()), {"fixed_components": ["0F1A3C22-1B7E-4A2E-9D0C-11AA00000001"]})).result
    warn = [w for w in res.report.warnings if w.code == "pcf_unconnected_items"]
    assert warn and warn[0].details["items"] == ["INSTRUMENT-34"]


@pytest.mark.parametrize("options, loc", [
    ({"connection_tolerance": "abc"}, ("options", "connection_tolerance")),
    ({"connection_tolerance": -1.0}, ("options", "connection_tolerance")),
    ({"fixed_components": "FLANGE-1"}, ("options", "fixed_components")),
    ({"bogus": 1}, ("options", "bogus")),
    ("fast", ("options",)),
])
def test_bad_upload_options_are_rejected_with_their_field(options, loc):
    for name, body in (("x.pcf", (DATA / "e3d_plant_conflict.pcf").read_bytes()),
                       ("x.json", b'{"components": [{"id": "a", "kind": "pipe", "ports": [{"position": [0, 0, 0], '
                                  b'"direction": [-1, 0, 0]}, {"position": [1, 0, 0], "direction": [1, 0, 0]}]}]}')):
        with pytest.raises(InputRejected) as e:
            parse_upload(StoredInput.from_bytes(name, body), options)
        assert e.value.errors[0].loc[-len(loc):] == loc


def test_inline_item_with_a_rounded_centre_point_has_exactly_opposite_ports():
    text = ("UNITS-BORE MM\nUNITS-CO-ORDS MM\nPIPE\n    END-POINT 0 0 0 50\n    END-POINT 1000 0 0 50\n"
            "INSTRUMENT\n    END-POINT 1001.2 0 0 50\n    END-POINT 1201.2 0 0 50\n    CENTRE-POINT 1101.2 0.1 0\n"
            "VALVE-ANGLE\n    END-POINT 1201.2 0 0 50\n    END-POINT 1301.2 100 0 50\n    CENTRE-POINT 1301.2 0 0\n")
    req = parse_upload(StoredInput.from_bytes("x.pcf", text.encode()), None)
    inst = next(c for c in req.components if c.id == "INSTRUMENT-2")
    assert inst.ports[0].direction == [-1.0, 0.0, 0.0] and inst.ports[1].direction == [1.0, 0.0, 0.0]
    angle = next(c for c in req.components if c.id == "VALVE-ANGLE-3")
    assert angle.ports[1].direction == [0.0, 1.0, 0.0]  # a real angle item keeps its centre
    assert len(req.connections) == 2


def test_end_connection_marker_follows_its_port():
    text = ("UNITS-BORE MM\nUNITS-CO-ORDS MM\nPIPE\n    END-POINT 0 0 0 100\n    END-POINT 1000 0 0 100\n"
            "ELBOW\n    END-POINT 1002 1 0 100\n    END-POINT 1152 151 0 100\n    CENTRE-POINT 1152 1 0\n"
            "PIPE\n    END-POINT 1152 152 0 100\n    END-POINT 1152 2000 0 100\n"
            "END-CONNECTION-PIPELINE\n    CO-ORDS 1152 2000 0 100\n    PIPELINE-REFERENCE 100-CW-1002\n")
    req = parse_upload(StoredInput.from_bytes("x.pcf", text.encode()), {"fixed_components": ["PIPE-1"]})
    solved = solve(req)
    res = solved.result
    out = render_artifacts(req, solved)[0].data.decode().splitlines()
    end = next(c for c in res.components if c.id == "PIPE-3").ports[1].position
    assert [float(v) for v in out[-2].split()[1:4]] == end
    assert end != [1152.0, 2000.0, 0.0]


@pytest.mark.parametrize("digits", [0, 2, 4])
def test_loops_from_a_rounded_export_close_without_cuts(digits):
    """A PCF prints coordinates rounded, which bends catalogue angles by ~quantum / arm: in loops of
    elbows and tees that makes closure impossible unless the angles are restored (here: 9 loops, CRLF)."""
    from plantsolve.solvers.alignment.pcf_write import generate_pcf
    from plantsolve.solvers.alignment.synthetic import grid_network

    req = grid_network(4, 4, valve_every=5, tie_ins=((0, 0),), origin=(1e6, 2e5, 1e4), seed=5)
    text = re.sub(r"-?\d+\.\d+", lambda m: f"{float(m.group(0)):.{digits}f}", generate_pcf(req, req)).replace("\n", "\r\n")
    up = parse_upload(StoredInput.from_bytes("loops.pcf", text.encode()), {"fixed_components": ["ELBOW-1"]})
    assert len(up.connections) == len(req.connections)
    for c in up.components:
        if c.type in ("elbow", "tee", "cross"):
            D = np.array([p.direction for p in c.ports])
            G = np.abs(D @ D.T)
            assert np.all((G < 1e-15) | (np.abs(G - 1) < 1e-15))  # exact right angles and straight runs again
    res = solve(up).result
    assert res.converged and not res.cut_connections and res.max_position_error == 0.0
    (elbow,) = up.options.fixed_components  # ELBOW-1 is the first elbow's positional alias
    fixed_in = next(c for c in up.components if c.id == elbow)
    assert [p.position for p in next(c for c in res.components if c.id == elbow).ports] == [p.position for p in fixed_in.ports]


def test_a_bend_of_an_odd_angle_is_not_snapped():
    # an 88.6 degree pipe bend printed with 4 decimals stays 88.6 degrees
    th = np.radians(88.6)
    c = np.array([1000.0, 0, 0])
    e0, e1 = c - [300.0, 0, 0], c + 300.0 * np.array([np.cos(th), np.sin(th), 0])
    f = lambda v: " ".join(f"{x:.4f}" for x in v)
    text = f"BEND\n    END-POINT {f(e0)} 100\n    END-POINT {f(e1)} 100\n    CENTRE-POINT {f(c)}\n"
    text += f"PIPE\n    END-POINT {f(e1 + 1.0 * np.array([np.cos(th), np.sin(th), 0]))} 100\n    END-POINT {f(e1 + 900 * np.array([np.cos(th), np.sin(th), 0]))} 100\n"
    bend = parse_upload(StoredInput.from_bytes("b.pcf", text.encode()), None).components[0]
    d0, d1 = (np.array(p.direction) for p in bend.ports)
    assert np.degrees(np.arccos(-d0 @ d1)) == pytest.approx(88.6, abs=1e-4)


# ---------------------------------------------------------------- files cut short


def _plant3d_lines() -> list[str]:
    return _lines((DATA / "plant3d_cw_line.pcf").read_bytes().decode())


def test_a_plant3d_export_cut_after_pipe_warns_that_the_last_item_has_no_points():
    lines = _plant3d_lines()
    pipe = next(n for n, ln in enumerate(lines, 1) if n > 140 and ln.rstrip() == "PIPE")  # the run after the bend
    req = parse_upload(StoredInput.from_bytes("cut.pcf", "".join(lines[:pipe]).encode()), None)
    res = solve(req).result
    warnings = {w.code: w for w in res.report.warnings}
    cut = warnings["truncated_file"]
    assert cut.details["line"] == pipe and f"line {pipe}" in cut.message and "no END-POINT" in cut.message
    (unread,) = warnings["pcf_items_unread"].details["items"]
    assert unread["line"] == pipe and res.report.status == "warning"


def test_a_plant3d_export_cut_inside_an_end_point_line_warns_naming_its_item():
    lines = _plant3d_lines()
    pipe = next(n for n, ln in enumerate(lines, 1) if n > 140 and ln.rstrip() == "PIPE")
    text = "".join(lines[:pipe + 1]) + lines[pipe + 1][:26]  # '    END-POINT 13000.0000 2' of its second end
    res = solve(parse_upload(StoredInput.from_bytes("cut.pcf", text.encode()), None)).result
    cut = next(w for w in res.report.warnings if w.code == "truncated_file")
    assert cut.details == {"line": pipe, "id": cut.details["id"], "keyword": "PIPE", "last_line": pipe + 2}
    assert "could not be read whole" in cut.message
    held = next(w for w in res.report.warnings if w.code == "pcf_items_held").details["items"]
    assert [h["line"] for h in held] == [pipe]


def test_a_pcf_cut_after_its_only_component_keyword_is_refused_on_the_file():
    with pytest.raises(InputRejected) as e:
        parse_upload(StoredInput.from_bytes("cut.pcf", b"ISOGEN-FILES ISOGEN.FLS\r\nUNITS-CO-ORDS MM\r\nPIPE\r\n"), None)
    (fe,) = e.value.errors
    assert fe.loc == ("file",) and "line 3" in fe.msg and "no END-POINT" in fe.msg


@pytest.mark.parametrize("value", ["1e308", "-3e15"])
def test_an_item_with_a_coordinate_beyond_the_bound_is_held_not_the_file_refused(value):
    """A finite but absurd coordinate (an exporter's garbage float) is read like a non-finite one: its item is
    held and reported with its line; before, it overflowed the reader's neighbour search and refused the file."""
    text = "UNITS-CO-ORDS MM\n" + GOOD + f"PIPE\n    END-POINT 1000 0 0 100\n    END-POINT 2000 {value} 0 100\n"
    req = parse_upload(StoredInput.from_bytes("x.pcf", text.encode()), None)
    res = solve(req).result
    (entry,) = next(w for w in res.report.warnings if w.code == "pcf_items_held").details["items"]
    assert "beyond 1e+12" in entry["reason"] and entry["line"] == 5


def test_a_plant3d_export_cut_inside_a_record_after_the_points_warns_that_what_followed_is_missing():
    """Cut in the middle of an item's ITEM-CODE line (its points whole), the file was aligned as if it were complete:
    every item after the cut was lost without a word."""
    lines = _plant3d_lines()
    code = next(n for n, ln in enumerate(lines, 1) if n > 60 and ln.strip().startswith("ITEM-CODE"))
    text = "".join(lines[:code - 1]) + lines[code - 1][:-6]  # '    ITEM-CODE PIPSML' of 'PIPSMLS4S40'
    res = solve(parse_upload(StoredInput.from_bytes("cut.pcf", text.encode()), None)).result
    cut = next(w for w in res.report.warnings if w.code == "truncated_file")
    assert cut.details["last_line"] == code and "any items the file held after it are missing" in cut.message
