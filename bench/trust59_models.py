"""The models kinds (polyhedra, rigidity, dedup) given the mistakes trust58's bench does not make, through the real
API (TestClient, jobs run to their end), judged as ``bench/trust58_models.py`` judges (its ``child`` runs the cases):
wrong units with no header to say so, files cut mid-object, files of another kind, absurd numbers, shuffled order.

The outcome column: ``refused``, ``scaled``/``same``, ``warned <codes>``, and the rows to look at: ``500``,
``CRASH`` (a 422 saying only "malformed"), ``NO WORD`` (a flagged mistake answered with no new warning),
``OTHER ANSWER`` (an invariant mistake answered with other numbers), ``failed`` (accepted, refused after the 202).
Rows ``legit: …`` are files nothing is wrong with: ``quiet (right)``, or ``FALSE ALARM (<codes>)``.

    python bench/trust59_models.py [--ref /work/main /work/wt/trust59c] [--kinds polyhedra rigidity dedup]
        [--cases word ...]
"""

from __future__ import annotations

import json
import os
import random
import re
import struct
import sys

import mistakes_table as table  # bench/, the script's folder, is first on sys.path; one BLAS thread
import trust58_models  # its judge and child run this round's cases
from trust58_models import POLY, RIG, ROOT, _replace_once, _text

IN = 1 / 0.0254
LEGIT = "legit:"  # a file nothing is wrong with: its right outcome is no word beyond the clean file's
# but for the notes its own content calls for (a multiplier applied, a trailer missing after the data's end)
LEGIT_NOTES = {"zone_multipliers_applied", "truncated_file"}


def _box_stl_binary(dx: float, dy: float, dz: float) -> bytes:
    """A closed box room as a binary STL (12 outward triangles)."""
    c = [(x, y, z) for x in (0, dx) for y in (0, dy) for z in (0, dz)]
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    tris = [t for a, b, c_, d in quads for t in ((a, b, c_), (a, c_, d))]
    body = b"".join(struct.pack("<12fH", 0, 0, 0, *c[i], *c[j], *c[k], 0) for i, j, k in tris)
    return b"room".ljust(80, b" ") + struct.pack("<I", len(tris)) + body


def _step_renumbered_shuffled(text: str) -> str:
    """The STEP file's instances renumbered (ids spread and permuted) and written in another order."""
    lines = text.splitlines()
    data_at = lines.index("DATA;") + 1
    end_at = lines.index("ENDSEC;", data_at)
    ids = [int(m.group(1)) for m in (re.match(r"#(\d+)=", line) for line in lines[data_at:end_at]) if m]
    fresh = random.Random(59).sample(range(10, 10 * len(ids) + 10), len(ids))
    new = dict(zip(ids, fresh))
    body = [re.sub(r"#(\d+)", lambda m: f"#{new.get(int(m.group(1)), m.group(1))}", line)
            for line in lines[data_at:end_at]]
    random.Random(59).shuffle(body)
    return "\n".join(lines[:data_at] + body + lines[end_at:]) + "\n"


def _cut_mid_data(text: str, fraction: float) -> str:
    """The STEP file cut in the middle of an entity past ``fraction`` of its DATA section."""
    at = text.index("DATA;") + int((text.rindex("ENDSEC;") - text.index("DATA;")) * fraction)
    semi = text.index(";", at)
    return text[:semi - 3]


def _mpd_submodels_reversed(text: str) -> str:
    """The .mpd's first section (the main model) first, its sub-models after it in reverse order."""
    sections = re.split(r"(?m)^(?=0 FILE )", text)
    head, main, subs = sections[0], sections[1], sections[2:]
    return head + main + "".join(s if s.endswith("\n") else s + "\n" for s in reversed(subs))


def _mpd_cut_mid_submodel(text: str) -> str:
    """The .mpd cut in the middle of a part line of its last sub-model (a transfer that stopped)."""
    last = text.rindex("\n0 FILE ")
    lines = [m.start() for m in re.finditer(r"(?m)^1 ", text) if m.start() > last]
    at = lines[len(lines) // 2]
    return text[:at + 20]


def _idf_cut_mid_object(text: str) -> str:
    """The IDF cut inside its last BuildingSurface:Detailed, in the middle of a vertex."""
    at = text.rindex("BuildingSurface:Detailed")
    vertex = text.index("!- X,Y,Z Vertex 2", at)
    return text[:text.rindex(",", at, vertex) - 2]


def _ldraw_moved(text: str, turn: bool, shift: float) -> str:
    """Every top-level part and sub-model line of the main model turned 90 degrees about y (when ``turn``) and
    shifted by ``shift`` LDU along x: the same model elsewhere."""
    main_end = text.find("\n0 FILE ", text.find("0 FILE ") + 1) if text.lstrip().startswith("0 FILE") else -1
    head, tail = (text[:main_end], text[main_end:]) if main_end > 0 else (text, "")

    def moved(m: re.Match) -> str:
        w = m.group(0).split()
        x, y, z = (float(v) for v in w[2:5])
        a = [float(v) for v in w[5:14]]
        if turn:  # R = [[0,0,1],[0,1,0],[-1,0,0]]: x' = z, z' = -x
            x, z = z, -x
            a = a[6:9] + a[3:6] + [-v for v in a[0:3]]
        w[2:5] = [repr(x + shift), repr(y), repr(z)]
        w[5:14] = [repr(v) for v in a]
        return " ".join(w)
    return re.sub(r"(?m)^1 .*$", moved, head) + tail


def _obj_scaled(text: str, k: float) -> str:
    """Every vertex times ``k`` and the header's unit line dropped (a room drawn in another unit, no header)."""
    text = re.sub(r"(?m)^#.*units.*\n", "", text)
    return re.sub(r"(?m)^v (\S+) (\S+) (\S+)", lambda m: "v " + " ".join(f"{float(v) * k:.6f}" for v in m.groups()),
                  text)


def _gbxml_surfaces_reversed(text: str) -> str:
    """The gbXML's Surface elements in reverse order."""
    surfaces = re.findall(r"(?s)[ \t]*<Surface .*?</Surface>\n", text)
    first = text.index(surfaces[0])
    rest = text.replace("".join(surfaces), "", 1)
    assert rest != text
    return rest[:first] + "".join(reversed(surfaces)) + rest[first:]


def _step_wrapped(text: str, width: int = 80) -> str:
    """The DATA section's instances wrapped after commas at ``width`` characters, as some exporters write them."""
    out = []
    for line in text.splitlines():
        while line.startswith("#") and len(line) > width and "," in line[:width]:
            cut = line.rindex(",", 0, width) + 1
            out.append(line[:cut])
            line = line[cut:]
        out.append(line)
    return "\n".join(out) + "\n"


def _two_solids_stl(first: str) -> str:
    """Two box rooms as two named solids of one ASCII STL, ``first`` written first."""
    solids = {}
    for name, x0 in (("a", 0.0), ("b", 6.0)):
        c = [(x0 + x, y, z) for x in (0, 5) for y in (0, 4) for z in (0, 3)]
        quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
        facets = "".join("facet normal 0 0 0\nouter loop\n" + "".join(
            "vertex {} {} {}\n".format(*c[i]) for i in t) + "endloop\nendfacet\n"
            for a, b, c_, d in quads for t in ((a, b, c_), (a, c_, d)))
        solids[name] = f"solid {name}\n{facets}endsolid {name}\n"
    return solids[first] + solids["b" if first == "a" else "a"]


def _ply() -> bytes:
    return (ROOT / "examples/tube/scan.ply").read_bytes()


# (kind, mistake, file name, bytes, options, expect) with expect "same", "flag" or ("scaled", k)
def polyhedra_cases() -> list[tuple]:
    idf = _text("examples/polyhedra/two_offices.idf")
    four = _text(POLY / "4ZoneWithShading_Simple_1.idf")
    epjson = json.loads(_text(POLY / "4ZoneWithShading_Simple_1.epJSON"))
    gbxml = _text("examples/polyhedra/offices.xml")
    obj = _text(POLY / "sketchup_two_rooms.obj")
    ifc = _text(POLY / "ifcopenshell_spaces.ifc")
    room_m = _box_stl_binary(5.0, 4.0, 3.0)
    room_in = _box_stl_binary(5 * IN, 4 * IN, 3 * IN)
    reversed_ep = {k: dict(reversed(list(v.items()))) if isinstance(v, dict) else v
                   for k, v in reversed(list(epjson.items()))}
    return [
        ("polyhedra", "clean binary STL room (5 x 4 x 3 m)", "room.stl", room_m, None, "same"),
        ("polyhedra", "binary STL room drawn in inches, no units", "room.stl", room_in, None, "flag"),
        ("polyhedra", "binary STL cut short (last triangle half)", "room.stl", room_m[:-25], None, "flag"),
        ("polyhedra", "binary STL cut short, its header 'plywood shelf'", "room.stl",
         b"plywood shelf".ljust(80) + room_m[80:-25], None, "flag"),
        ("polyhedra", "binary STL cut short, its header '{part 7}'", "room.stl", b"{part 7}".ljust(80) + room_m[80:-25],
         None, "flag"),
        ("polyhedra", f"{LEGIT} one-zone STL tower in metres (30 x 30 x 60 m)", "tower.stl",
         _box_stl_binary(30.0, 30.0, 60.0), None, "flag"),
        ("polyhedra", f"{LEGIT} one-zone STL atrium in metres (20 x 12 x 150 m)", "atrium.stl",
         _box_stl_binary(20.0, 12.0, 150.0), None, "flag"),
        ("polyhedra", "binary STL hall 10 x 8 x 3.5 m drawn in inches, no units", "room.stl",
         _box_stl_binary(10 * IN, 8 * IN, 3.5 * IN), None, "flag"),
        ("polyhedra", "binary STL with a NaN vertex", "room.stl",
         room_m[:84 + 12] + struct.pack("<f", float("nan")) + room_m[84 + 16:], None, "flag"),
        ("polyhedra", "clean ASCII STL of two solids", "rooms.stl", _two_solids_stl("a").encode(), None, "same"),
        ("polyhedra", "ASCII STL solids in the other order", "rooms.stl", _two_solids_stl("b").encode(), None,
         "same"),
        ("polyhedra", "PLY scan named .stl", "room.stl", _ply(), None, "flag"),
        ("polyhedra", "PLY scan named .obj", "room.obj", _ply(), None, "flag"),
        ("polyhedra", "PCF named .idf", "zones.idf", (ROOT / "examples/alignment/ladder.pcf").read_bytes(), None,
         "flag"),
        ("polyhedra", "perfmap CSV named .idf", "zones.idf", (ROOT / "examples/perfmap/n3_fan_map.csv").read_bytes(),
         None, "flag"),
        ("polyhedra", "clean SketchUp OBJ (metres)", "rooms.obj", obj.encode(), None, "same"),
        ("polyhedra", "SketchUp OBJ drawn in inches, header dropped", "rooms.obj", _obj_scaled(obj, IN).encode(),
         None, "flag"),
        ("polyhedra", "SketchUp OBJ drawn in mm, header dropped", "rooms.obj", _obj_scaled(obj, 1000).encode(), None,
         "flag"),
        ("polyhedra", "OBJ room drawn as one face listed both ways", "rooms.obj",
         b"o room\nv 0 0 0\nv 5 0 0\nv 5 4 0\nv 0 4 0\nf 1 2 3 4\nf 4 3 2 1\n", None, "flag"),
        ("polyhedra", "SketchUp OBJ with a NaN vertex", "rooms.obj",
         _replace_once(obj, "v 4.000000 3.000000 0.000000", "v nan 3.000000 0.000000").encode(), None, "flag"),
        ("polyhedra", "SketchUp OBJ drawn in cm, header dropped", "rooms.obj", _obj_scaled(obj, 100).encode(), None,
         "flag"),
        ("polyhedra", "clean idf", "zones.idf", idf.encode(), None, "same"),
        ("polyhedra", "idf entered clockwise, rules say counterclockwise", "zones.idf",
         _replace_once(idf, "Counterclockwise,", "Clockwise,").encode(), None, "flag"),
        ("polyhedra", "idf cut mid-object (in a vertex)", "zones.idf", _idf_cut_mid_object(idf).encode(), None,
         "flag"),
        ("polyhedra", "idf without office B's surfaces (its Zone kept)", "zones.idf",
         "".join(o for o in re.split(r"(?m)^(?=\S)", idf) if not ("Office B Thermal Zone" in o and o.startswith(
             ("BuildingSurface", "Fenestration")))).encode(), None, "flag"),
        ("polyhedra", "idf zone multiplier 1e6", "zones.idf",
         re.sub(r"(?m)^(\s*)1,(\s*!- Multiplier)", r"\g<1>1000000,\2", idf, count=1).encode(), None, "flag"),
        ("polyhedra", "idf zone multiplier 20000", "zones.idf",
         re.sub(r"(?m)^(\s*)1,(\s*!- Multiplier)", r"\g<1>20000,\2", idf, count=1).encode(), None, "flag"),
        ("polyhedra", "idf zone multiplier 0", "zones.idf",
         re.sub(r"(?m)^(\s*)1,(\s*!- Multiplier)", r"\g<1>0,\2", idf, count=1).encode(), None, "flag"),
        ("polyhedra", "idf zone multiplier 2.5", "zones.idf",
         re.sub(r"(?m)^(\s*)1,(\s*!- Multiplier)", r"\g<1>2.5,\2", idf, count=1).encode(), None, "flag"),
        ("polyhedra", f"{LEGIT} idf zone multiplier 32 (MultiStory's 4 x 8)", "zones.idf",
         re.sub(r"(?m)^(\s*)1,(\s*!- Multiplier)", r"\g<1>32,\2", idf, count=1).encode(), None, "flag"),
        ("polyhedra", "idf a vertex NaN", "zones.idf",
         re.sub(r"(?m)^  5, 4, 0,(?=\s*!- X,Y,Z Vertex 1)", "  NaN, 4, 0,", idf, count=1).encode(), None,
         "flag"),
        ("polyhedra", "clean 4ZoneWithShading idf", "four.idf", four.encode(), None, "same"),
        ("polyhedra", "epJSON of it, objects and names reversed", "four.epJSON", json.dumps(reversed_ep).encode(),
         None, "same"),
        ("polyhedra", "clean IFC spaces", "spaces.ifc", ifc.encode(), None, "same"),
        ("polyhedra", "IFC spaces renumbered and reordered", "spaces.ifc", _step_renumbered_shuffled(ifc).encode(),
         None, "same"),
        ("polyhedra", "IFC spaces cut mid-entity", "spaces.ifc", _cut_mid_data(ifc, 0.8).encode(), None, "flag"),
        ("polyhedra", "IFC spaces cut mid-entity (90 %: 3 spaces named, a 4th past the cut)", "spaces.ifc",
         _cut_mid_data(ifc, 0.9).encode(), None, "flag"),
        ("polyhedra", f"{LEGIT} IFC spaces without their trailer 'END-ISO-10303-21;'", "spaces.ifc",
         ifc[:ifc.rindex("END-ISO-10303-21;")].encode(), None, "flag"),
        ("polyhedra", "IFC spaces in mm stated METRE", "spaces.ifc",
         _replace_once(ifc, "IFCSIUNIT(*,.LENGTHUNIT.,.MILLI.,.METRE.)",
                       "IFCSIUNIT(*,.LENGTHUNIT.,$,.METRE.)").encode(), None, "flag"),
        ("polyhedra", "clean gbXML", "offices.xml", gbxml.encode(), None, "same"),
        ("polyhedra", "gbXML surfaces reversed", "offices.xml", _gbxml_surfaces_reversed(gbxml).encode(), None,
         "same"),
        ("polyhedra", "gbXML cut mid-element", "offices.xml", gbxml[:len(gbxml) * 2 // 3].encode(), None, "flag"),
    ]


def rigidity_cases() -> list[tuple]:
    radar = _text(RIG / "889-1-RadarTruck.mpd")
    tie = _text(RIG / "6965-1-TIEIntercep_4h4MXk5.mpd")
    wall = _text("examples/rigidity/hinged_wall.ldr")
    first_part = re.search(r"(?m)^1 \S+ (\S+) ", wall)
    return [
        ("rigidity", "clean .mpd (radar truck)", "radar.mpd", radar.encode(), None, "same"),
        ("rigidity", "main model turned 90 degrees (radar truck)", "radar.mpd",
         _ldraw_moved(radar, True, 0).encode(), None, "same"),
        ("rigidity", "main model 1e6 LDU along (radar truck)", "radar.mpd", _ldraw_moved(radar, False, 1e6).encode(),
         None, "same"),
        ("rigidity", "sub-models in reverse order (radar truck)", "radar.mpd", _mpd_submodels_reversed(radar).encode(),
         None, "same"),
        ("rigidity", ".mpd cut mid-sub-model (radar truck)", "radar.mpd", _mpd_cut_mid_submodel(radar).encode(),
         None, "flag"),
        ("rigidity", ".mpd with CRLF line ends (radar truck)", "radar.mpd", radar.replace("\n", "\r\n").encode(),
         None, "same"),
        ("rigidity", "clean .mpd (TIE)", "tie.mpd", tie.encode(), None, "same"),
        ("rigidity", "sub-models in reverse order (TIE)", "tie.mpd", _mpd_submodels_reversed(tie).encode(), None,
         "same"),
        ("rigidity", ".mpd cut mid-sub-model (TIE)", "tie.mpd", _mpd_cut_mid_submodel(tie).encode(), None, "flag"),
        ("rigidity", "clean ldr (hinged wall)", "wall.ldr", wall.encode(), None, "same"),
        ("rigidity", "ldr with the form's units mm, contact_tolerance 0.5 (hinged wall)", "wall.ldr", wall.encode(),
         {"units": "mm", "contact_tolerance": 0.5}, "flag"),
        ("rigidity", "ldr turned 90 degrees (hinged wall)", "wall.ldr", _ldraw_moved(wall, True, 0).encode(), None,
         "same"),
        ("rigidity", "ldr 1e7 LDU along (hinged wall)", "wall.ldr", _ldraw_moved(wall, False, 1e7).encode(), None,
         "same"),
        ("rigidity", "ldr a position NaN (hinged wall)", "wall.ldr",
         (wall[:first_part.start(1)] + "nan" + wall[first_part.end(1):]).encode(), None, "flag"),
        ("rigidity", "ldr a position 1e12 (hinged wall)", "wall.ldr",
         (wall[:first_part.start(1)] + "1e12" + wall[first_part.end(1):]).encode(), None, "flag"),
        ("rigidity", "ldr separated by tabs, with a byte-order mark (hinged wall)", "wall.ldr",
         b"\xef\xbb\xbf" + re.sub(r"(?m)^(1) ", "1\t", wall).encode(), None, "same"),
        ("rigidity", "two bricks, the second placed by a scaling matrix", "two.ldr",
         b"1 16 0 0 0 1 0 0 0 1 0 0 0 1 3001.dat\n1 16 0 -24 0 2 0 0 0 2 0 0 0 2 3001.dat\n", None, "flag"),
        ("rigidity", "two bricks, the second's position NaN", "two.ldr",
         b"1 16 0 0 0 1 0 0 0 1 0 0 0 1 3001.dat\n1 16 nan -24 0 1 0 0 0 1 0 0 0 1 3001.dat\n", None, "flag"),
        ("rigidity", "the truck sub-model placed by a scaling matrix (radar truck)", "radar.mpd",
         _replace_once(radar, "1 0 0 0 0 1 0 0 0 1 0 0 0 1 889 - Truck.ldr",
                       "1 0 0 0 0 2 0 0 0 2 0 0 0 2 889 - Truck.ldr").encode(), None, "flag"),
        ("rigidity", "two bricks, and a sub-model of six placed by a scaling matrix", "tower.mpd",
         ("0 FILE main.ldr\n1 16 0 0 0 1 0 0 0 1 0 0 0 1 3001.dat\n1 16 0 -24 0 1 0 0 0 1 0 0 0 1 3001.dat\n"
          "1 16 0 -48 0 2 0 0 0 2 0 0 0 2 tower.ldr\n0 FILE tower.ldr\n"
          + "".join(f"1 16 0 {-24 * k} 0 1 0 0 0 1 0 0 0 1 3001.dat\n" for k in range(6))).encode(), None, "flag"),
        ("rigidity", "PLY scan named .ldr", "model.ldr", _ply(), None, "flag"),
        ("rigidity", "binary STL named .ldr", "model.ldr", _box_stl_binary(5, 4, 3), None, "flag"),
        ("rigidity", "perfmap CSV named .mpd", "model.mpd", (ROOT / "examples/perfmap/n3_fan_map.csv").read_bytes(),
         None, "flag"),
    ]


def dedup_cases() -> list[tuple]:
    zoo = _text("examples/dedup/zoo_ifc2x3.ifc")
    zoo_mm = re.sub(r"IFCSIUNIT\(\*,\.LENGTHUNIT\.,\$,\.METRE\.\)", "IFCSIUNIT(*,.LENGTHUNIT.,.MILLI.,.METRE.)", zoo,
                    count=1)
    return [
        ("dedup", "clean ifc (zoo)", "zoo.ifc", zoo.encode(), None, "same"),
        ("dedup", "zoo renumbered and reordered", "zoo.ifc", _step_renumbered_shuffled(zoo).encode(), None, "same"),
        ("dedup", "zoo wrapped at 80 columns", "zoo.ifc", _step_wrapped(zoo).encode(), None, "same"),
        ("dedup", "zoo with CRLF line ends and a byte-order mark", "zoo.ifc",
         b"\xef\xbb\xbf" + zoo.replace("\n", "\r\n").encode(), None, "same"),
        ("dedup", "zoo cut mid-entity (80 %)", "zoo.ifc", _cut_mid_data(zoo, 0.8).encode(), None, "flag"),
        ("dedup", "zoo cut mid-entity (30 %)", "zoo.ifc", _cut_mid_data(zoo, 0.3).encode(), None, "flag"),
        ("dedup", "zoo stated MILLI over metres", "zoo.ifc", zoo_mm.encode(), None, "flag"),
        ("dedup", "zoo tolerance 1 (mm meant, file in m)", "zoo.ifc", zoo.encode(), {"tolerance": 0.001 * 1000},
         "flag"),
        ("dedup", "zoo asked in units mm", "zoo.ifc", zoo.encode(), {"units": "mm"}, "flag"),
        ("dedup", "PLY scan named .ifc", "model.ifc", _ply(), None, "flag"),
        ("dedup", "binary STL named .ifc", "model.ifc", _box_stl_binary(5, 4, 3), None, "flag"),
        ("dedup", "PCF named .ifc", "model.ifc", (ROOT / "examples/alignment/ladder.pcf").read_bytes(), None,
         "flag"),
        ("dedup", "perfmap CSV named .ifc", "model.ifc", (ROOT / "examples/perfmap/n3_fan_map.csv").read_bytes(), None,
         "flag"),
    ]


CASES = {"polyhedra": polyhedra_cases, "rigidity": rigidity_cases, "dedup": dedup_cases}


def child(kinds: list[str], only: list[str] | None) -> None:
    sys.path.insert(0, os.getcwd())
    trust58_models.CASES = CASES
    trust58_models.child(kinds, only)


def main() -> None:
    args = table.arguments(__doc__, kinds=CASES).parse_args()
    if args.child:
        child(args.kinds, args.cases)
        return
    trees = table.trees(args, __file__, mine="this tree", before=None)
    table.markdown(trees, ["kind", "mistake", "this tree", "what it says"],
                   lambda r: [r["kind"], r["mistake"], _legit(r["mistake"], r["outcome"]),
                              table.excerpt(r.get("said", ""), 140)],
                   lambda ref: _legit(ref["mistake"], ref["outcome"]))


def _legit(mistake: str, outcome: str) -> str:
    """A legitimate file's outcome as right or wrong: no new warning is right, a warning a false alarm."""
    if not mistake.startswith(LEGIT) or not outcome.startswith(("NO WORD", "warned")):
        return outcome
    alarms = sorted(set(outcome.removeprefix("warned ").split(",")) - LEGIT_NOTES - {"NO WORD"})
    return f"FALSE ALARM ({','.join(alarms)})" if alarms else "quiet (right)"


if __name__ == "__main__":
    main()
