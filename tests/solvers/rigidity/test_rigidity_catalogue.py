"""The generated parts catalogue (LDCad shadow library snaps): the derivation script on a small library
written the way the shadow library writes it, the data file against the hand-coded parts, and models of
official parts: known parts, exactly the joints they are built with, no collision."""

from __future__ import annotations

import gzip
import importlib.util
import json
from collections import Counter
from pathlib import Path

import numpy as np
import pytest

from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.rigidity import generated
from plantsolve.solvers.rigidity.assembly import Assembly
from plantsolve.solvers.rigidity.catalogue import CATALOGUE, generated_part, lookup, mate
from plantsolve.solvers.rigidity.solve import solve
from plantsolve.solvers.rigidity.upload import parse_upload

HERE = Path(__file__).parent
SCRIPT = HERE.parents[2] / "scripts" / "ldcad_catalogue.py"


def _script():
    spec = importlib.util.spec_from_file_location("ldcad_catalogue", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _write(root: Path, rel: str, text: str) -> None:
    path = root / rel
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)


def test_script_resolves_inheritance_includes_grids_clears_and_scaling(tmp_path):
    ldraw, shadow = tmp_path / "ldraw", tmp_path / "shadow"
    # a 1 x 2 technic brick drawn as LDraw draws it: studs through stud.dat, a subpart, an axle primitive
    _write(ldraw, "parts/9001.dat", "0 Technic Brick  1 x  2 Test\n0 Name: 9001.dat\n"
           "1 16 -10 0 0 1 0 0 0 1 0 0 0 1 stud.dat\n1 16 10 0 0 1 0 0 0 1 0 0 0 1 stud.dat\n"
           "1 16 0 0 0 1 0 0 0 1 0 0 0 1 s\\9001s01.dat\n")
    _write(ldraw, "parts/s/9001s01.dat", "0 ~sub\n4 16 -20 0 -10 20 0 -10 20 24 -10 -20 24 -10\n"
           "4 16 -20 0 10 20 0 10 20 24 10 -20 24 10\n")
    _write(ldraw, "p/stud.dat", "0 Stud\n4 16 -6 0 -6 6 0 -6 6 -4 -6 -6 -4 -6\n")
    _write(ldraw, "p/axle.dat", "0 Technic Axle\n2 24 0 0 0 0 1 0\n")
    # an axle drawn as axle.dat stretched 40 along y, turned onto x
    _write(ldraw, "parts/9002.dat", "0 Technic Axle  2 Test\n1 16 -20 0 0 0 40 0 -1 0 0 0 0 1 axle.dat\n")
    # a part whose shadow clears what it inherits and says it itself
    _write(ldraw, "parts/9003.dat", "0 Plate Test\n1 16 0 0 0 1 0 0 0 1 0 0 0 1 stud.dat\n")
    _write(shadow, "p/stud.dat", "0 !LDCAD SNAP_CYL [ID=studC] [gender=M] [caps=one] [secs=R 6 4]\n")
    _write(shadow, "p/axle.dat", "0 !LDCAD SNAP_CYL [id=axle] [gender=M] [caps=none] [secs=A 6 1] [slide=true] "
           "[pos=0 1 0] [scale=YOnly]\n")
    _write(shadow, "p/connhole.dat", "0 !LDCAD SNAP_CYL [id=connhole] [gender=F] [caps=none] "
           "[secs=R 8 2   R 6 16   R 8 2] [center=true] [slide=true]\n")
    _write(shadow, "parts/s/9001s01.dat", "0 !LDCAD SNAP_CYL [gender=F] [caps=one] [secs=R 6 20] [pos=0 24 0] "
           "[grid=C 2 1 20 0]\n")
    _write(shadow, "parts/9001.dat", "0 !LDCAD SNAP_INCL [ref=connhole.dat] [pos=0 10 0] [ori=1 0 0 0 0 1 0 -1 0] "
           "[grid=C 1 1 20 0]\n")
    _write(shadow, "parts/9003.dat", "0 !LDCAD SNAP_CLEAR\n0 !LDCAD SNAP_CYL [gender=M] [caps=one] [secs=R 6 4] "
           "[pos=0 0 10]\n")
    parts = _script().derive(ldraw, shadow)
    assert set(parts) == {"9001", "9002", "9003"}
    assert parts["9001"]["b"] == [-20.0, -4.0, -10.0, 20.0, 24.0, 10.0]

    def points(number):
        return Counter(c for c in generated.connectors(parts[number]["s"]) if not c[0].startswith("fit_"))

    # every cylinder also as stated (the fits the points do not name): the included technic hole as connhole.dat
    # says it, centred on (0, 10, 0) along z
    fits = Counter(c for c in generated.connectors(parts["9001"]["s"]) if c[0].startswith("fit_"))
    assert fits[("fit_f", (0.0, 10.0, -10.0), (0.0, 0.0, 1.0), 20.0, (("R", 8.0, 2.0), ("R", 6.0, 16.0),
                                                                      ("R", 8.0, 2.0)))] == 1
    assert sum(fits.values()) == 5 and sum(1 for c in fits if c[0] == "fit_m") == 2
    assert points("9001") == Counter({("stud", (-10.0, 0.0, 0.0), (0.0, -1.0, 0.0)): 1,
                                      ("stud", (10.0, 0.0, 0.0), (0.0, -1.0, 0.0)): 1,
                                      ("antistud", (-10.0, 24.0, 0.0), (0.0, 1.0, 0.0)): 1,
                                      ("antistud", (10.0, 24.0, 0.0), (0.0, 1.0, 0.0)): 1,
                                      # the hole with its bore's length: connhole.dat's 20 LDU
                                      ("pinhole", (0.0, 10.0, 0.0), (0.0, 0.0, 1.0), 0.0, (), 20.0): 1})
    # 40 LDU of axle: one run from end to end along x (its direction the stretched primitive's), as the
    # hand-coded 3704
    (axle,) = points("9002")
    assert axle[0] == "axle" and axle[3] == 40.0 and abs(axle[2][0]) == 1.0
    assert axle[1][0] + axle[2][0] * 40.0 / 2 == 0.0  # centred on the origin
    assert list(points("9003")) == [("stud", (0.0, 0.0, 10.0), (0.0, -1.0, 0.0))]


def test_script_writes_the_same_bytes_twice(tmp_path):
    ldraw, shadow = tmp_path / "ldraw", tmp_path / "shadow"
    _write(ldraw, "parts/9004.dat", "0 Brick Test\n1 16 0 0 0 1 0 0 0 1 0 0 0 1 stud.dat\n")
    _write(ldraw, "p/stud.dat", "0 Stud\n2 24 0 0 0 0 -4 0\n")
    _write(shadow, "p/stud.dat", "0 !LDCAD SNAP_CYL [gender=M] [caps=one] [secs=R 6 4]\n")
    script = _script()
    outs = []
    for k in range(2):
        out = tmp_path / f"out{k}.tsv.gz"
        assert script.main(["--ldraw", str(ldraw), "--shadow", str(shadow), "--out", str(out)]) == 0
        outs.append(out.read_bytes())
    assert outs[0] == outs[1]
    header, part = gzip.decompress(outs[0]).decode().splitlines()
    assert json.loads(header)["units"].startswith("LDU") and part.startswith("9004\t")
    assert json.loads(part.split("\t", 1)[1])["n"] == "Brick Test"


def test_the_data_file_holds_thousands_of_parts_with_licence_and_attribution():
    assert len(generated.numbers()) > 10_000
    data = Path(generated.DATA).parent
    assert "Attribution-ShareAlike 4.0" in (data / "LICENSE").read_text()
    readme = (data / "README.md").read_text()
    assert "Roland Melkert" in readme and "CC BY-SA 4.0" in readme and "LDraw.org" in readme


COMPARABLE = {"stud", "antistud", "pin", "pinhole", "axle", "axlehole"}


def _comparable(shape) -> set:
    out = set()
    for c in shape.connectors:
        kind = "hinge" if c.type in ("hinge_a", "hinge_b", "finger") else c.type
        if kind not in COMPARABLE | {"hinge"}:
            continue
        direction = c.direction if kind in ("stud", "antistud") else tuple(abs(v) for v in c.direction)
        if c.length > 0 and kind == "hinge":  # a run of hinge fingers: its centre on the hinge line
            centre = np.asarray(c.point) + np.asarray(c.direction) * c.length / 2
            out.add((kind, tuple(float(v) for v in centre), tuple(float(v) for v in direction)))
            continue
        if c.length > 0:  # a run (an axle): its two ends, whichever it starts from
            ends = np.array([c.point, np.asarray(c.point) + np.asarray(c.direction) * c.length], float)
            out.add((kind, frozenset(tuple(float(v) for v in e) for e in ends), tuple(float(v) for v in direction)))
            continue
        out.add((kind, tuple(float(v) for v in c.point), tuple(float(v) for v in direction)))
    return out


@pytest.mark.parametrize("number", sorted(CATALOGUE))
def test_generated_parts_match_the_hand_coded_ones(number):
    hand, made = _comparable(CATALOGUE[number]), _comparable(generated_shape(number))
    if number in ("3648", "3648a", "3648b", "3649"):  # the real gears have more holes than the hand-coded axle hole
        assert hand <= made
    else:
        assert made == hand


def generated_shape(number):
    shape = generated_part(number)
    assert shape is not None, number
    return shape


def test_lookup_prefers_the_hand_coded_part_and_finds_the_rest_in_the_generated_catalogue():
    brick = lookup("3001.dat")  # the hand-coded brick, with the generated part's snap cylinders added
    assert brick.connectors[:len(CATALOGUE["3001"].connectors)] == CATALOGUE["3001"].connectors
    assert {c.type for c in brick.connectors[len(CATALOGUE["3001"].connectors):]} <= {"fit_m", "fit_f"}
    axle = lookup("3707")  # the hand-coded axle 8 alone states only its typed run: one cylinder more, 160 LDU
    assert [(c.type, c.length, c.profile) for c in axle.connectors[1:]] == [("fit_m", 160.0, (("A", 6.0, 160.0),))]
    plate = lookup("parts\\3023B.DAT")
    assert plate is not None and "Plate" in plate.name and plate.box_size == (40.0, 8.0, 20.0)
    assert lookup("no_such_part.dat") is None


def parse(path: Path):
    return parse_upload(StoredInput.from_bytes(path.name, path.read_bytes()), None)


EXPECTED = Counter({
    ("rigid", "stud", "3035", "3001"): 1, ("rigid", "stud", "3035", "3003"): 1, ("rigid", "stud", "3035", "3010"): 1,
    ("rigid", "stud", "3035", "3022"): 1, ("rigid", "stud", "3035", "3701"): 1, ("rigid", "stud", "3035", "3937"): 1,
    ("rigid", "stud", "3035", "44301"): 1, ("rigid", "stud", "3035", "44302"): 1,
    ("rigid", "stud", "3001", "14417"): 1, ("rigid", "stud", "3001", "3023b"): 1, ("rigid", "stud", "3001", "3623"): 1,
    ("rigid", "stud", "3003", "3068b"): 1, ("rigid", "stud", "3010", "3710"): 1, ("rigid", "stud", "3710", "3069b"): 1,
    ("rigid", "stud", "3701", "3623"): 1, ("rigid", "stud", "3938", "3004"): 1,
    ("hinge", "stud", "3001", "4085c"): 1, ("hinge", "stud", "3022", "3005"): 1, ("hinge", "stud", "3022", "3062b"): 1,
    ("hinge", "stud", "3022", "4073"): 1, ("hinge", "stud", "3701", "3024"): 1,
    ("hinge", "pin", "3701", "3673"): 2, ("hinge", "pin", "3673", "32524"): 2,
    ("cylindrical", "axle", "32524", "3705"): 1, ("rigid", "axle", "3705", "3713"): 1,
    ("ball", "ball", "14417", "14704"): 1, ("hinge", "clip", "4085c", "87994"): 1,
    ("hinge", "hinge", "44302", "44301"): 1, ("hinge", "hinge", "3937", "3938"): 1,
})


def _joints(request, result) -> Counter:
    number = {p.id: p.part for p in request.parts}
    return Counter((j.type, j.origin, number[j.bodies[0]], number[j.bodies[1]]) for j in result.joints)


def test_a_model_of_official_parts_is_known_and_makes_exactly_its_joints():
    request = parse(HERE / "official_parts.ldr")
    result = solve(request).result
    assert len(request.parts) == 30 and result.unknown_parts == []
    assert _joints(request, result) == EXPECTED
    assert result.collisions == []  # pins in holes, axle in beam and bush, ball in socket, clip on bar, hinges
    # each pin spins (2), the axle with its bush turns and slides in the beam's round hole (2), the socket
    # plate turns on the ball (3), the clip plate on its one stud and the bar in the clip (2), the hinge
    # top (1), four parts on one stud each (4); the locking hinge plates both sit on the base
    assert result.dof == 14
    assert [j.axis for j in result.joints if j.type == "ball"] == [None]


def test_a_generated_box_part_pushed_into_another_is_a_collision():
    text = (HERE / "official_parts.ldr").read_text().replace("1 16 20 -32 -20 1 0 0 0 1 0 0 0 1 3068b.dat",
                                                           "1 16 20 -28 -20 1 0 0 0 1 0 0 0 1 3068b.dat")
    request = parse_upload(StoredInput.from_bytes("sunk.ldr", text.encode()), None)
    result = solve(request).result
    number = {p.id: p.part for p in request.parts}
    assert [(number[c.bodies[0]], number[c.bodies[1]], round(c.depth, 6)) for c in result.collisions] == \
        [("3003", "3068b", 4.0)]


def test_a_ball_joint_connects_whatever_the_socket_turns():
    assembly = Assembly()
    assembly.add_part("ball", "14417", (0, 0, 0))
    turned = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])  # a quarter turn about z
    ball = np.array([0.0, 4.0, -20.0])
    socket = np.array(next(c.point for c in lookup("14704").connectors if c.type == "socket"))
    found = assembly.add_part("socket", "14704", ball - turned @ socket, turned.reshape(-1))
    assert [(c.kind, c.point) for c in found] == [("ball", (0, 4, -20))]


def test_an_official_set_model_is_mostly_known():
    """OMR 889 Radar Truck (CC BY 2.0, omr/README.md): every part known (the four tyres too, though the
    wheel holders 122c01 carry no rim snap for them to fit)."""
    request = parse(HERE / "omr" / "889-1-RadarTruck.mpd")
    result = solve(request).result
    assert len(request.parts) == 35 and result.unknown_parts == []
    joints = _joints(request, result)
    assert joints[("hinge", "hinge", "3938", "3937")] == 1  # the radar dish's hinge, tilted as the set has it
    assert joints[("rigid", "stud", "3795", "122c01")] == 2  # both wheel holders under the chassis plate
    assert result.collisions == []


def test_an_official_mini_set_is_all_known_every_part_joined_and_nothing_collides():
    """OMR 30051 X-wing Mini (CC BY 2.0, omr/README.md): round plates on a half pin's short end, an
    antenna in a round brick, clips on bars, wings on brackets."""
    request = parse(HERE / "omr" / "30051-1-X-wingFighter-Mini.mpd")
    result = solve(request).result
    assert len(request.parts) == 61 and result.unknown_parts == []
    joined = {b for j in result.joints for b in j.bodies}
    assert {p.id for p in request.parts} == joined
    joints = _joints(request, result)
    assert joints[("hinge", "stud", "4274", "6141")] == 4  # each engine's half pin holds a round plate
    assert joints[("hinge", "stud", "6141", "6141")] == 4  # and that one the next
    assert joints[("hinge", "stud", "3957a", "3062b")] == 4
    assert joints[("hinge", "clip", "6019", "61184")] == 4
    assert result.collisions == []


def _fits_rigidly_there_only(host: str, part: str, off: tuple[float, float, float]) -> None:
    """``part`` placed at ``host``'s origin fits it by one rigid group connection; placed ``off`` it fits nothing."""
    assembly = Assembly()
    assembly.add_part("host", host, (0, 0, 0))
    found = assembly.add_part("part", part, (0, 0, 0))
    assert [c.kind for c in found] == ["group"]
    assert assembly.analyse().mobility.dof == 0
    other = Assembly()
    other.add_part("host", host, (0, 0, 0))
    assert other.add_part("part", part, off) == []


def test_a_tyre_fits_its_rim_through_their_snap_group_and_nothing_else():
    _fits_rigidly_there_only("4624", "3641", (0, 0, 10))  # off the rim: no fit


def test_docking_offers_poses_for_a_generated_part():
    path = HERE / "official_parts.ldr"
    request = parse_upload(StoredInput.from_bytes(path.name, path.read_bytes()), {"dock": {"part": "3023b", "limit": 3}})
    poses = solve(request).result.docking
    assert len(poses) == 3 and all(p.part == "3023b" and p.connections == 2 for p in poses)


def test_script_gives_stud_tubes_their_anti_stud_at_the_mouth_whatever_their_height(tmp_path):
    ldraw, shadow = tmp_path / "ldraw", tmp_path / "shadow"
    # a 2 x 2 brick's tube (stud4.dat drawn from y = -4 to 0, placed upside down and stretched 5 times: y 4..24)
    # and a plate's (stretched once: y 4..8); the shadow states nothing for stud4.dat, as the real one
    _write(ldraw, "p/stud4.dat", "0 Stud Tube Open\n4 16 -8 -4 -8 8 -4 -8 8 0 -8 -8 0 -8\n")
    _write(ldraw, "parts/9005.dat", "0 Brick  2 x  2 Test\n1 16 0 4 0 1 0 0 0 -5 0 0 0 1 stud4.dat\n"
           "4 16 -20 0 -20 20 0 -20 20 24 -20 -20 24 -20\n")
    _write(ldraw, "parts/9006.dat", "0 Plate  2 x  2 Test\n1 16 0 4 0 1 0 0 0 -1 0 0 0 1 stud4.dat\n"
           "4 16 -20 0 -20 20 0 -20 20 8 -20 -20 8 -20\n")
    _write(shadow, "p/stud4.dat", "0 LDCad shadow info\n0 //!LDCAD SNAP_CYL [id=aStud] [gender=F] [caps=one] "
           "[secs=R 6 4]\n")
    parts = _script().derive(ldraw, shadow)
    for number, bottom in (("9005", 24.0), ("9006", 8.0)):
        points = [c for c in generated.connectors(parts[number]["s"]) if not c[0].startswith("fit_")]
        assert points == [("antistud", (0.0, bottom, 0.0), (0.0, 1.0, 0.0))], number


def test_script_gives_a_wheel_pin_without_shadow_the_pin_of_wpin_dat_once(tmp_path):
    ldraw, shadow = tmp_path / "ldraw", tmp_path / "shadow"
    # wpin4.dat draws its pin itself and has no shadow (as the real one); wpin3.dat draws wpin.dat and inherits it
    _write(ldraw, "p/wpin.dat", "0 Wheel Holding Pin\n4 16 -4 0 0 4 0 0 4 -12 0 -4 -12 0\n")
    _write(ldraw, "p/wpin4.dat", "0 Wheel Holding Pin for Pull Back Motor\n4 16 -4 0 0 4 0 0 4 -12 0 -4 -12 0\n")
    _write(ldraw, "p/wpin3.dat", "0 Wheel Holding Pin with 3 Fillets\n1 16 0 0 0 1 0 0 0 1 0 0 0 1 wpin.dat\n")
    _write(shadow, "p/wpin.dat", "0 LDCad shadow info\n"
           "0 !LDCAD SNAP_CYL [gender=M] [caps=one] [secs=R 4 11   _L 4.25 1]\n")
    # two parts with a pin on their right side along +x at y = 5 (the pull-back motor's placement, turned)
    for number, pin in (("9007", "wpin4.dat"), ("9008", "wpin3.dat")):
        _write(ldraw, f"parts/{number}.dat", f"0 Motor Test\n1 16 32 5 0 0 -1 0 -1 0 0 0 0 -1 {pin}\n"
               "4 16 -20 0 -20 20 0 -20 20 8 -20 -20 8 -20\n")
    parts = _script().derive(ldraw, shadow)
    for number in ("9007", "9008"):
        (snap,) = parts[number]["s"]  # one pin, not one own and one inherited
        assert snap == ["cyl", "M", "one", 0, [32.0, 5.0, 0.0], [1.0, 0.0, 0.0], [["R", 4.0, 11.0], ["_L", 4.25, 1.0]]]


def test_script_gives_a_primitive_without_edge_lines_its_edged_twins_snaps_once(tmp_path):
    ldraw, shadow = tmp_path / "ldraw", tmp_path / "shadow"
    # stud3a.dat is stud3.dat's post (radius 4, y -4..0) without its base edges; the shadow states stud3.dat only
    post = "1 16 0 -4 0 4 0 0 0 4 0 0 0 4 4-4cyli.dat\n"
    _write(ldraw, "p/stud3.dat", "0 Stud Tube Solid\n" + post + "1 16 0 0 0 4 0 0 0 1 0 0 0 4 4-4edge.dat\n")
    _write(ldraw, "p/stud3a.dat", "0 Stud Tube Solid without Base Edges\n" + post)
    _write(ldraw, "p/4-4cyli.dat", "0 Cylinder 1.0\n4 16 1 1 0 -1 1 0 -1 0 0 1 0 0\n")
    _write(ldraw, "p/4-4edge.dat", "0 Circle 1.0\n2 24 1 0 0 -1 0 0\n")
    # a primitive named like a twin whose title is not its twin's "without ...": not the same solid
    _write(ldraw, "p/studa.dat", "0 Something Else\n" + post)
    _write(ldraw, "p/stud.dat", "0 Stud\n" + post)
    _write(shadow, "p/stud3.dat", "0 !LDCAD SNAP_CYL [id=stud3] [gender=M] [caps=one] [secs=R 4 4] [scale=YOnly]\n")
    _write(shadow, "p/stud.dat", "0 !LDCAD SNAP_CYL [id=studC] [gender=M] [caps=one] [secs=R 6 4]\n")
    # a Technic brick 1 x 2's post (stud3a.dat upside down, 1.5 times as long: y 18..24), a slope that states its
    # post itself over the one it draws, and one that clears it by id
    under = "1 16 0 18 0 1 0 0 0 -1.5 0 0 0 1 stud3a.dat\n"
    _write(ldraw, "parts/9101.dat", "0 Technic Brick  1 x  2 Test\n" + under)
    _write(ldraw, "parts/9102.dat", "0 Slope Test\n" + under)
    _write(shadow, "parts/9102.dat", "0 !LDCAD SNAP_CYL [gender=M] [caps=one] [secs=R 4 6] [pos=0 24 0]\n")
    _write(ldraw, "parts/9103.dat", "0 Cleared Test\n" + under + "1 16 0 0 0 1 0 0 0 1 0 0 0 1 stud.dat\n")
    _write(shadow, "parts/9103.dat", "0 !LDCAD SNAP_CLEAR [id=stud3]\n")
    _write(ldraw, "parts/9104.dat", "0 Other Test\n1 16 0 0 0 1 0 0 0 1 0 0 0 1 studa.dat\n")
    parts = _script().derive(ldraw, shadow)
    assert parts["9101"]["s"] == [["cyl", "M", "one", 0, [0.0, 18.0, 0.0], [0.0, 1.0, 0.0], [["R", 4.0, 6.0]]]]
    assert parts["9102"]["s"] == [["cyl", "M", "one", 0, [0.0, 24.0, 0.0], [0.0, -1.0, 0.0], [["R", 4.0, 6.0]]]]
    assert [s[4] for s in parts["9103"]["s"]] == [[0.0, 0.0, 0.0]]  # the stud only
    assert "9104" not in parts


def test_parts_the_shadow_library_renamed_since_the_ldraw_release_keep_their_own_lines():
    # The shadow library renamed 32556 to 32556a and 6192 to 6192a with LDraw's 2026-02 release; the 2024-05 library
    # still names them so. Their own lines (restored, data/README.md): the long pin one 60-LDU cylinder centred on
    # its collar (not the one 20-LDU half its sub-files state), 6192 an anti-stud under each of its 4 x 2 studs.
    pin = generated_shape("32556")
    assert [(c.point, abs(c.direction[0]), c.length) for c in pin.connectors if c.type == "fit_m"] == [
        ((-30.0, 0.0, 0.0), 1.0, 60.0)]
    assert sorted(c.point[0] for c in pin.connectors if c.type == "pin") == [-20.0, 0.0, 20.0]
    curved = generated_shape("6192")
    under = {c.point for c in curved.connectors if c.type == "antistud" and c.point[1] == 24.0}
    assert {(x, 24.0, z) for x in (-30.0, -10.0, 10.0, 30.0) for z in (-10.0, 10.0)} <= under


def test_script_writes_primitives_and_subparts_with_snaps_keyed_by_their_reference_and_scale_flag(tmp_path):
    ldraw, shadow = tmp_path / "ldraw", tmp_path / "shadow"
    _write(ldraw, "parts/9001.dat", "0 Brick Test\n1 16 0 0 0 1 0 0 0 1 0 0 0 1 s\\9001s01.dat\n")
    _write(ldraw, "parts/s/9001s01.dat", "0 ~sub\n1 16 10 0 0 1 0 0 0 1 0 0 0 1 stud.dat\n")
    _write(ldraw, "p/stud.dat", "0 Stud\n4 16 -6 0 -6 6 0 -6 6 -4 -6 -6 -4 -6\n")
    _write(ldraw, "p/axle.dat", "0 Technic Axle\n2 24 0 0 0 0 1 0\n")
    _write(ldraw, "p/box5.dat", "0 Box\n4 16 1 0 1 -1 0 1 -1 0 -1 1 0 -1\n")  # no snaps: left out
    _write(shadow, "p/stud.dat", "0 !LDCAD SNAP_CYL [gender=M] [caps=one] [secs=R 6 4]\n")
    _write(shadow, "p/axle.dat", "0 !LDCAD SNAP_CYL [gender=M] [caps=none] [secs=A 6 1] [scale=YOnly]\n")
    subfiles: dict = {}
    parts = _script().derive(ldraw, shadow, subfiles)
    assert set(parts) == {"9001"} and set(subfiles) == {"stud.dat", "axle.dat", "s/9001s01.dat"}
    # the parts' lines keep their 7 fields; a sub-file's cylinder says whether a scaled placement stretches it
    assert parts["9001"]["s"] == [["cyl", "M", "one", 0, [10.0, 0.0, 0.0], [0.0, -1.0, 0.0], [["R", 6.0, 4.0]]]]
    assert subfiles["s/9001s01.dat"]["s"] == [["cyl", "M", "one", 0, [10.0, 0.0, 0.0], [0.0, -1.0, 0.0],
                                               [["R", 6.0, 4.0]], 0]]
    assert subfiles["axle.dat"]["s"][0][-1] == 1 and subfiles["stud.dat"]["b"] == [-6.0, -4.0, -6.0, 6.0, 0.0, -6.0]
    assert _script().derive(ldraw, shadow) == parts  # without a subfiles dict: the parts alone, as before


def test_the_open_centre_technic_bricks_keep_the_frame_of_the_part_they_were_moved_to():
    # 32531 (Technic brick 4 x 6, open centre) is a `~Moved to 32531a` file that turns 32531a a quarter turn about y;
    # official models naming 32531 draw it in 32531a's own frame: its 6-long side along x, an end hole centred at
    # x = -50 and one at x = 50 (y = 10), along x. Two pins along x, each with one half in an end hole, are pinned
    # (a hinge each); a third pin along z where the turned frame would put an end hole (z = -50) meets nothing, as
    # 32531a has no hole there.
    text = ("0 Name: moved.ldr\n1 71 0 0 0 1 0 0 0 1 0 0 0 1 32531.dat\n"
            "1 0 -60 10 0 1 0 0 0 1 0 0 0 1 2780.dat\n1 0 60 10 0 1 0 0 0 1 0 0 0 1 2780.dat\n"
            "1 0 0 10 -60 0 0 -1 0 1 0 1 0 0 2780.dat\n")
    request = parse_upload(StoredInput.from_bytes("moved.ldr", text.encode()), None)
    result = solve(request).result
    assert result.unknown_parts == []
    assert _joints(request, result) == Counter({("hinge", "pin", "32531", "2780"): 2})
    assert lookup("32531").number == "32531" and lookup("32531").box_size == lookup("32531a").box_size
    assert lookup("32531").box_size[0] == 120.0 and lookup("32532").box_size[0] == 160.0


def test_script_starts_a_finger_run_at_its_position_when_it_is_not_centred(tmp_path):
    ldraw, shadow = tmp_path / "ldraw", tmp_path / "shadow"
    _write(ldraw, "parts/9005.dat", "0 Hinge Test\n2 24 -20 0 0 20 0 0\n")
    # 4715's lines: two runs of 3 + 4 + 4 LDU along x from x = -19 and x = 8, symmetric about the part's centre
    _write(shadow, "parts/9005.dat",
           "0 !LDCAD SNAP_FGR [genderOfs=M] [center=false] [seq=3 4 4] [radius=4] [pos=-19 0 0] "
           "[ori=0 -1 0 1 0 0 0 0 1]\n"
           "0 !LDCAD SNAP_FGR [genderOfs=M] [center=false] [seq=4 4 3] [radius=4] [pos=8 0 0] "
           "[ori=0 -1 0 1 0 0 0 0 1]\n"
           "0 !LDCAD SNAP_FGR [genderOfs=F] [seq=4 4] [radius=4] [pos=0 -10 0] [ori=0 -1 0 1 0 0 0 0 1]\n")
    runs = sorted((c[1][0], c[3]) for c in generated.connectors(_script().derive(ldraw, shadow)["9005"]["s"]))
    assert runs == [(-19.0, 11.0), (-4.0, 8.0), (8.0, 11.0)]  # (start along x, length); the last one centred on x = 0


def test_data_file_places_the_uncentred_finger_runs_where_the_shadow_library_states_them():
    """4715 (stretcher wheels) states two runs of 11 LDU with ``center=false`` from x = -19 and x = 8: symmetric about
    its centre, each a pitch's half from it; read centred they were (-24.5, -13.5) and (2.5, 13.5)."""
    spans = sorted(tuple(sorted((c[1][0], c[1][0] + c[2][0] * c[3]))) for c in
                   generated.connectors(generated.record("4715")["s"]) if c[0] == "finger")
    assert spans == [(-20.0, 0.0), (-19.0, -8.0), (0.0, 20.0), (8.0, 19.0)]


def test_script_reads_an_ungrouped_generic_snap_as_a_fit_of_its_bounding_shape_and_size(tmp_path):
    ldraw, shadow = tmp_path / "ldraw", tmp_path / "shadow"
    _write(ldraw, "parts/9006.dat", "0 Glass Test\n2 24 -10 0 0 10 0 0\n")
    _write(shadow, "parts/9006.dat", "0 !LDCAD SNAP_GEN [gender=M] [bounding=box 20 54.0 2] [pos=0 58 -4]\n"
           "0 !LDCAD SNAP_GEN [gender=M] [bounding=sph 4] [pos=0 0 0]\n")
    snaps = _script().derive(ldraw, shadow)["9006"]["s"]
    assert ["shp", "M", "box 20 54 2", [0.0, 58.0, -4.0], [0.0, -1.0, 0.0]] in snaps
    assert ("shape:box 20 54 2:M", (0.0, 58.0, -4.0), (0.0, -1.0, 0.0)) in generated.connectors(snaps)


def test_a_pane_fits_its_frame_through_their_ungrouped_generic_snaps_and_nothing_else():
    """2494 states only an ungrouped generic box (20 x 54 x 2), the slot of its frame 2493b the same box female: the
    pane was unknown (no snap read), now it is known and held rigidly in its frame, and only there."""
    assert lookup("2494") is not None and lookup("87612") is not None  # the plane's front glass the same way
    assert mate("shape:box 20 54 2:M", "shape:box 20 54 2:F") == "group"
    assert mate("shape:box 20 54 2:M", "shape:box 26 29.8 2:F") is None  # another size: no fit
    assert mate("shape:box 20 54 2:M", "group:box 20 54 2:F") is None  # nor a group's snap
    _fits_rigidly_there_only("2493b", "2494", (0, 0, 20))  # a stud pitch off the slot: no fit


def test_script_keeps_a_clips_radius_and_a_clip_of_another_radius_than_a_bars_is_no_bar_clip(tmp_path):
    ldraw, shadow = tmp_path / "ldraw", tmp_path / "shadow"
    _write(ldraw, "parts/9007.dat", "0 Clip Test\n2 24 -10 0 0 10 0 0\n")
    # 753's holder (radius 6), a bar's clip (radius 4) and one stating no radius (LDCad's default: a bar's)
    _write(shadow, "parts/9007.dat", "0 !LDCAD SNAP_CLP [radius=6] [length=8] [pos=0 8 -30]\n"
           "0 !LDCAD SNAP_CLP [radius=4] [length=8] [center=true] [pos=0 4 -20]\n"
           "0 !LDCAD SNAP_CLP [length=4] [center=true] [pos=0 4 20]\n")
    snaps = _script().derive(ldraw, shadow)["9007"]["s"]
    assert [s[4] for s in snaps] == [6.0, 4.0, 4.0]
    assert [c[0] for c in generated.connectors(snaps)] == ["rodclip", "clip", "clip"]
    assert generated.connectors(snaps)[0] == ("rodclip", (0.0, 4.0, -30.0), (0.0, -1.0, 0.0), 0.0,
                                              (("R", 6.0, 8.0),), 8.0)
    assert mate("rodclip", "bar") is None and mate("clip", "bar") == "clip"


@pytest.mark.parametrize("number, radius", [("753", 6.0), ("509", 6.0), ("4006", 6.0), ("55299", 6.0),
                                            ("3652", 6.0), ("2312", 9.0), ("4085c", 4.0),
                                            ("3873", 1.5)])
def test_data_file_keeps_the_radius_the_shadow_library_states_for_a_clip(number, radius):
    clips = [c for c in generated.connectors(generated.record(number)["s"]) if c[0] in ("clip", "rodclip")]
    assert clips and {c[4][0][1] for c in clips} == {radius}
    assert {c[0] for c in clips} == {"clip" if radius == 4.0 else "rodclip"}


def test_script_reads_a_grouped_clip_as_a_pivot_of_its_group_and_gives_the_groups_cylinders_one(tmp_path):
    ldraw, shadow = tmp_path / "ldraw", tmp_path / "shadow"
    _write(ldraw, "parts/9010.dat", "0 Universal Joint End Test\n2 24 -10 0 0 10 0 0\n")
    _write(ldraw, "parts/9011.dat", "0 Universal Joint Centre Test\n2 24 -10 0 0 10 0 0\n")
    # 3712's clip and 3326b's two arms as the shadow library states them; a cylinder of a group no clip names (an
    # electric plug's) stays a cylinder only
    _write(shadow, "parts/9010.dat", "0 !LDCAD SNAP_CLP [group=uniJnt] [radius=6] [length=20] [center=true] "
           "[slide=false] [pos=0 0 -30] [ori=0 -1 0 1 0 0 0 0 1]\n")
    _write(shadow, "parts/9011.dat",
           "0 !LDCAD SNAP_CYL [group=uniJnt] [gender=M] [caps=two] [secs=R 6 20] [center=true] [ori=0 -1 0 1 0 0 0 0 1]\n"
           "0 !LDCAD SNAP_CYL [group=uniJnt] [gender=M] [caps=two] [secs=R 6 20] [center=true] "
           "[ori=-1 0 0 0 -1 0 0 0 1]\n"
           "0 !LDCAD SNAP_CYL [group=elec] [gender=F] [caps=one] [secs=R 6 4] [pos=0 0 40]\n")
    parts = _script().derive(ldraw, shadow)
    assert parts["9010"]["s"] == [["pvt", "F", "unijnt", [0.0, 0.0, -30.0], [1.0, 0.0, 0.0]]]
    arms = [s for s in parts["9011"]["s"] if s[0] == "pvt"]
    assert arms == [["pvt", "M", "unijnt", [0.0, 0.0, 0.0], [1.0, 0.0, 0.0]],
                    ["pvt", "M", "unijnt", [0.0, 0.0, 0.0], [0.0, 1.0, 0.0]]]
    assert [s[0] for s in parts["9011"]["s"]] == ["cyl", "pvt", "cyl", "pvt", "cyl"]
    assert generated.connectors(parts["9010"]["s"]) == (("pivot:unijnt:F", (0.0, 0.0, -30.0), (1.0, 0.0, 0.0)),)
    assert mate("pivot:unijnt:F", "pivot:unijnt:M") == "hinge"
    assert mate("pivot:unijnt:F", "group:unijnt:M") is None and mate("pivot:unijnt:F", "bar") is None


def test_a_universal_joint_hinges_each_end_on_its_arm_of_the_centre_and_nothing_off_it():
    """3712 (end) clips on an arm of 3326b (centre), the shadow library's uniJnt group: the centre was joined to
    nothing (7784's Batmobile floated it). Two ends on the two arms: two hinges, about x and about y, through the
    centre's origin."""
    turned = (0, 1, 0, 1, 0, 0, 0, 0, -1)  # local x onto y, z onto -z: the second end faces the first
    assembly = Assembly()
    assembly.add_part("centre", "3326b", (0, 0, 0))
    first = assembly.add_part("a", "3712", (0, 0, 30))  # its clip 30 LDU along its -z: at the centre, along x
    second = assembly.add_part("b", "3712", (0, 0, -30), turned)
    assert [(c.kind, c.point, c.axis) for c in first] == [("hinge", (0, 0, 0), (1, 0, 0))]
    assert [(c.kind, c.point, c.axis) for c in second] == [("hinge", (0, 0, 0), (0, 1, 0))]
    apart = Assembly()
    apart.add_part("centre", "3326b", (0, 0, 0))
    assert apart.add_part("a", "3712", (0, 0, 50)) == []  # a stud pitch off: its clip is not on the arm

