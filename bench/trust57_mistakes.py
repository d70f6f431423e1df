"""The mistakes users make with every reader, sent through the real API (TestClient, jobs run to their end) and,
for what is accepted, read again by the kind's reader directly: a cut file, an empty one, another kind's file, an
absurd number (1e308, NaN, negative, 0), a header or option whose unit contradicts the values, shuffled rows, UTF-16
with its mark, Windows-1252, CRLF, decimal commas.

Each case expects one of:

- ``same``: the file means what the clean file means (an encoding, line ends, row order): read to the same request
  (lists compared as sets), or refused naming the line — never read to other numbers without a word;
- ``flag``: a refusal naming the field or line, or a job whose report has a warning the clean file's has not.

The outcome column: ``refused`` (4xx), ``same`` (the reading equals the clean file's), ``warned <codes>`` (a job with
new warnings), and the rows to look at: ``500``, ``CRASH`` (the reader raised: a 422 saying only "malformed"),
``NO WORD`` (a job that succeeded with no new warning on a flagged mistake), ``OTHER READING`` (an invariant mistake
read to other numbers; its job's summary beside it when it differs).

    python bench/trust57_mistakes.py [--ref /tmp/mistakes-base] [--kinds perfmap tube ...]
    (cd /tmp/mistakes-base && PYTHONPATH=. python $OLDPWD/bench/trust57_mistakes.py --child) > before.jsonl
    python bench/trust57_mistakes.py --ref-rows before.jsonl
"""

from __future__ import annotations

import hashlib
import json
import os
import random
import re
import sys
import time
from pathlib import Path

import mistakes_table as table  # bench/, the script's folder, is first on sys.path; one BLAS thread

ROOT = Path(__file__).resolve().parent.parent  # the inputs come from this tree, whichever tree reads them


def _text(path: str) -> str:
    return (ROOT / path).read_text(encoding="utf-8")


def _cut(text: str) -> bytes:
    """Cut in the middle of a line past the middle of the file, as a transfer that stopped."""
    at = int(len(text) * 0.6)
    while at < len(text) and text[at] in " \n\r\t":
        at += 1
    return text[: at + 2].encode()


def _shuffled_lines(text: str, keep: int = 0) -> bytes:
    lines = text.splitlines()
    head, body = lines[:keep], lines[keep:]
    random.Random(57).shuffle(body)
    return ("\n".join(head + body) + "\n").encode()


def _shuffled_blocks(text: str, starts: re.Pattern, tail: int = 0) -> bytes:
    """The blocks (a line matching ``starts`` and what follows it up to the next) in another order; the last
    ``tail`` lines stay last."""
    lines = text.splitlines()
    end = lines[len(lines) - tail:] if tail else []
    lines = lines[:len(lines) - tail]
    first = next(i for i, line in enumerate(lines) if starts.match(line))
    blocks, current = [], []
    for line in lines[first:]:
        if starts.match(line) and current:
            blocks.append(current)
            current = []
        current.append(line)
    blocks.append(current)
    random.Random(57).shuffle(blocks)
    return ("\n".join(lines[:first] + [line for b in blocks for line in b] + end) + "\n").encode()


def _utf16(text: str) -> bytes:
    return "\ufeff".encode("utf-16-le") + text.encode("utf-16-le")


def _crlf(text: str) -> bytes:
    return text.replace("\r\n", "\n").replace("\n", "\r\n").encode()


def _replace_once(text: str, old: str, new: str) -> str:
    assert old in text, old
    return text.replace(old, new, 1)


def _decimal_commas(text: str) -> str:
    return re.sub(r"(?<=\d)\.(?=\d)", ",", text)


# Each case: (kind, mistake, file name, bytes, options, expect, reference bytes for "same" (None: the clean file))
Case = tuple


def perfmap_cases() -> list[Case]:
    csv = _text("examples/perfmap/n3_fan_map.csv")
    lines = csv.splitlines()
    first = lines[1].split(",")
    gasturb = (ROOT / "tests/solvers/perfmap/data/gasturb/bigfand.map").read_text()
    as_json = _text("examples/perfmap/n3_fan_map.json")
    ldr, ifc = _text("examples/rigidity/hinged_wall.ldr"), _text("examples/dedup/tunnel_3rings.ifc")
    pcf = _text("examples/alignment/ladder.pcf")
    latin = "\n".join([lines[0] + ",Bemerkung"] + [row + ",Prüfstand Größe" for row in lines[1:]]) + "\n"
    european = "\n".join(";".join(cell.replace(".", ",") for cell in line.split(",")) for line in lines) + "\n"
    percent_header = csv.replace("efficiency", "efficiency [%]", 1)
    mm_fractions = "\n".join([lines[0]] + [",".join(r.split(",")[:4] + [f"{float(r.split(',')[4]) * 100:g}"])
                                           for r in lines[1:]]) + "\n"
    row1 = ",".join(first)
    absurd = lambda i, value: _replace_once(csv, row1, ",".join(first[:i] + [value] + first[i + 1:])).encode()
    mixed = json.loads(as_json)
    mixed["units"] = {**(mixed.get("units") or {}), "efficiency": "%"}
    for p in mixed["positions"]:
        p["efficiency"] = [e * 100 for e in p["efficiency"]]
    mixed["positions"][0]["efficiency"][1] /= 100  # one typed as a fraction among per cent
    return [
        ("perfmap", "clean csv", "map.csv", csv.encode(), None, "same", None),
        ("perfmap", "cut csv", "map.csv", _cut(csv), None, "flag", None),
        ("perfmap", "empty csv", "map.csv", b"", None, "flag", None),
        ("perfmap", "header only", "map.csv", (lines[0] + "\n").encode(), None, "flag", None),
        ("perfmap", "shuffled rows", "map.csv", _shuffled_lines(csv, keep=1), None, "same", None),
        ("perfmap", "CRLF", "map.csv", _crlf(csv), None, "same", None),
        ("perfmap", "UTF-16 with BOM", "map.csv", _utf16(csv), None, "same", None),
        ("perfmap", "UTF-8 BOM", "map.csv", b"\xef\xbb\xbf" + csv.encode(), None, "same", None),
        ("perfmap", "Windows-1252 header", "map.csv", latin.encode("cp1252"), None, "same", latin.encode()),
        ("perfmap", "decimal commas, ';' separated", "map.csv", european.encode(), None, "same", None),
        ("perfmap", "efficiency [%] holding fractions", "map.csv", percent_header.encode(), None, "flag", None),
        ("perfmap", "efficiency in per cent, no unit", "map.csv", mm_fractions.encode(), None, "flag", None),
        ("perfmap", "speed [rpm] holding relative speeds", "map.csv",
         csv.replace("theta,phi", "theta [deg],speed [rpm]", 1).encode(), None, "flag", None),
        ("perfmap", "speed [%] holding relative speeds", "map.csv",
         csv.replace("theta,phi", "theta [deg],speed [%]", 1).encode(), None, "flag", None),
        ("perfmap", "flow 1e308", "map.csv", absurd(2, "1e308"), None, "flag", None),
        ("perfmap", "flow NaN", "map.csv", absurd(2, "NaN"), None, "flag", None),
        ("perfmap", "flow negative", "map.csv", absurd(2, "-1104.338"), None, "flag", None),
        ("perfmap", "flow 0", "map.csv", absurd(2, "0"), None, "flag", None),
        ("perfmap", "pressure 0", "map.csv", absurd(3, "0"), None, "flag", None),
        ("perfmap", "efficiency 7 (of a fraction)", "map.csv", absurd(4, "7"), None, "flag", None),
        ("perfmap", "options.units.flow lbm/s (a unit for a bare column)", "map.csv", csv.encode(),
         {"units": {"flow": "lbm/s"}}, "flag", None),
        ("perfmap", "an IFC renamed .csv", "map.csv", ifc.encode(), None, "flag", None),
        ("perfmap", "an LDraw renamed .csv", "map.csv", ldr.encode(), None, "flag", None),
        ("perfmap", "a PCF renamed .map", "map.map", pcf.encode(), None, "flag", None),
        ("perfmap", "a tube scan renamed .csv", "map.csv", _text("examples/tube/scan.xyz").replace(" ", ",").encode(),
         None, "flag", None),
        ("perfmap", "clean GasTurb .map", "fan.map", gasturb.encode(), None, "same", None),
        ("perfmap", "cut GasTurb .map", "fan.map", _cut(gasturb), None, "flag", None),
        ("perfmap", "GasTurb .map CRLF", "fan.map", _crlf(gasturb), None, "same", gasturb.encode()),
        ("perfmap", "GasTurb .map UTF-16", "fan.map", _utf16(gasturb), None, "same", gasturb.encode()),
        ("perfmap", "GasTurb .map 1e308", "fan.map", _replace_once(gasturb, "26.40000", "1e308").encode(), None,
         "flag", None),
        ("perfmap", "GasTurb .map NaN", "fan.map", _replace_once(gasturb, "26.40000", "NaN").encode(), None,
         "flag", None),
        ("perfmap", "clean xlsx", "map.xlsx", _xlsx(lines), None, "same", None),
        ("perfmap", "xlsx efficiency [%] holding fractions", "map.xlsx",
         _xlsx(percent_header.splitlines()), None, "flag", None),
        ("perfmap", "xlsx shuffled rows", "map.xlsx", _xlsx(_shuffled_lines(csv, keep=1).decode().splitlines()),
         None, "same", None),
        ("perfmap", "cut xlsx", "map.xlsx", _xlsx(lines)[:3000], None, "flag", None),
        ("perfmap", "a CSV renamed .xlsx", "map.xlsx", csv.encode(), None, "flag", None),
        ("perfmap", "clean .json", "map.json", as_json.encode(), None, "same", None),
        ("perfmap", ".json per cent with one fraction (loc file.)", "map.json", json.dumps(mixed).encode(), None,
         "flag", None),
        ("perfmap", "cut .json", "map.json", _cut(as_json), None, "flag", None),
        ("perfmap", "a tube .json request", "map.json", _text("examples/tube/scan_request.json").encode(), None,
         "flag", None),
    ]


def _xlsx(rows: list[str]) -> bytes:
    """A workbook of one sheet holding the CSV's rows (numbers as numbers), as Excel saves a rig's table."""
    import io

    import openpyxl

    book = openpyxl.Workbook()
    sheet = book.active
    for row in rows:
        sheet.append([float(c) if re.fullmatch(r"-?[\d.]+(e-?\d+)?", c) else c for c in row.split(",")])
    out = io.BytesIO()
    book.save(out)
    return out.getvalue()


def _radians_nominal() -> str:
    lines = _text("examples/tube/nominal_lra.csv").splitlines()
    out = lines[:2]
    for row in lines[2:]:
        cells = row.split(",")
        if len(cells) == 5 and cells[3]:
            cells[3] = f"{float(cells[3]) * 3.141592653589793 / 180:.4f}"
        out.append(",".join(cells))
    return "\n".join(out) + "\n"


def tube_cases() -> list[Case]:
    xyz = _text("examples/tube/scan.xyz")
    first = xyz.splitlines()[0]
    x0 = first.split()[0]
    ply = (ROOT / "examples/tube/scan.ply").read_bytes()
    in_metres = "\n".join(" ".join(f"{float(v) / 1000:.6f}" for v in line.split()) for line in xyz.splitlines()) + "\n"
    latin = "# Messung Rohr 3 — Prüfstand\n" + xyz
    scan_json = json.loads(_text("examples/tube/scan_request.json"))
    return [
        ("tube", "clean xyz", "scan.xyz", xyz.encode(), None, "same", None),
        ("tube", "cut xyz", "scan.xyz", _cut(xyz), None, "flag", None),
        ("tube", "empty xyz", "scan.xyz", b"", None, "flag", None),
        ("tube", "shuffled points", "scan.xyz", _shuffled_lines(xyz), None, "same", None),
        ("tube", "CRLF", "scan.xyz", _crlf(xyz), None, "same", None),
        ("tube", "UTF-16 with BOM", "scan.xyz", _utf16(xyz), None, "same", None),
        ("tube", "Windows-1252 comment", "scan.xyz", latin.encode("cp1252"), None, "same", latin.encode()),
        ("tube", "decimal commas, ';' separated", "scan.xyz",
         _decimal_commas(xyz).replace(" ", ";").encode(), None, "same", None),
        ("tube", "decimal commas, ',' separated", "scan.csv",
         ("x,y,z\n" + _decimal_commas(xyz).replace(" ", ",")).encode(), None, "same", None),
        ("tube", "nominal angle_deg holding radians", "scan.xyz", xyz.encode(),
         {"nominal_csv": _radians_nominal()}, "flag", None),
        ("tube", "nominal bend_radius_mm holding metres", "scan.xyz", xyz.encode(),
         {"nominal_csv": _text("examples/tube/nominal_lra.csv").replace(",18\n", ",0.018\n")}, "flag", None),
        ("tube", "header [mm] over metres", "scan.xyz", ("x [mm] y [mm] z [mm]\n" + in_metres).encode(), None,
         "flag", None),
        ("tube", "header [m] over millimetres", "scan.xyz", ("x [m] y [m] z [m]\n" + xyz).encode(), None,
         "flag", None),
        ("tube", "file_units m over millimetres", "scan.xyz", xyz.encode(), {"file_units": "m"}, "flag", None),
        ("tube", "a coordinate 1e308", "scan.xyz", _replace_once(xyz, first, first.replace(x0, "1e308", 1)).encode(),
         None, "flag", None),
        ("tube", "a coordinate NaN", "scan.xyz", _replace_once(xyz, first, first.replace(x0, "nan", 1)).encode(),
         None, "flag", None),
        ("tube", "pipe_radius negative", "scan.xyz", xyz.encode(), {"pipe_radius": -6}, "flag", None),
        ("tube", "pipe_radius 0", "scan.xyz", xyz.encode(), {"pipe_radius": 0}, "flag", None),
        ("tube", "pipe_radius 1e308", "scan.xyz", xyz.encode(), {"pipe_radius": 1e308}, "flag", None),
        ("tube", "an LDraw renamed .xyz", "scan.xyz", _text("examples/rigidity/hinged_wall.ldr").encode(), None,
         "flag", None),
        ("tube", "a perfmap CSV", "scan.csv", _text("examples/perfmap/n3_fan_map.csv").encode(), None, "flag", None),
        ("tube", "an IFC renamed .stl", "scan.stl", _text("examples/dedup/tunnel_3rings.ifc").encode(), None,
         "flag", None),
        ("tube", ".json a point 1e308", "scan.json", json.dumps({**scan_json, "points": [[1e308, 0.0, 0.0]] +
                                                                  scan_json["points"][1:]}).encode(), None, "flag", None),
        ("tube", "clean PLY", "scan.ply", ply, None, "same", None),
        ("tube", "cut PLY", "scan.ply", ply[: len(ply) * 3 // 5], None, "flag", None),
        ("tube", "a PCF renamed .ply", "scan.ply", _text("examples/alignment/ladder.pcf").encode(), None, "flag",
         None),
        ("tube", "a CSV renamed .las", "scan.las", _text("examples/perfmap/n3_fan_map.csv").encode(), None, "flag",
         None),
        ("tube", "a CSV renamed .e57", "scan.e57", _text("examples/perfmap/n3_fan_map.csv").encode(), None, "flag",
         None),
        ("tube", "an STL box (no tube)", "scan.stl", (ROOT / "tests/solvers/polyhedra/data/ascii_box.stl").read_bytes(),
         None, "flag", None),
    ]


def alignment_cases() -> list[Case]:
    pcf = _text("examples/alignment/ladder.pcf")
    latin = _replace_once(pcf, "PIPELINE-REFERENCE 100-CW-1001", "PIPELINE-REFERENCE 100-CW-1001 Kühlwasser")
    inch = pcf.replace("UNITS-CO-ORDS MM", "UNITS-CO-ORDS INCH")
    return [
        ("alignment", "clean pcf", "ladder.pcf", pcf.encode(), None, "same", None),
        ("alignment", "cut pcf", "ladder.pcf", _cut(pcf), None, "flag", None),
        ("alignment", "empty pcf", "ladder.pcf", b"", None, "flag", None),
        ("alignment", "shuffled components", "ladder.pcf",
         _shuffled_blocks(pcf, re.compile(r"^(ELBOW|TEE|PIPE|FLANGE|VALVE|REDUCER)")), None, "same", None),
        ("alignment", "CRLF", "ladder.pcf", _crlf(pcf), None, "same", None),
        ("alignment", "UTF-16 with BOM", "ladder.pcf", _utf16(pcf), None, "same", None),
        ("alignment", "Windows-1252 name", "ladder.pcf", latin.encode("cp1252"), None, "same", latin.encode()),
        ("alignment", "decimal commas", "ladder.pcf", _decimal_commas(pcf).encode(), None, "same", None),
        ("alignment", "UNITS-CO-ORDS INCH over mm", "ladder.pcf", inch.encode(), None, "flag", None),
        ("alignment", "an END-POINT 1e308", "ladder.pcf", _replace_once(pcf, "1000150.0000", "1e308").encode(), None,
         "flag", None),
        ("alignment", "an END-POINT NaN", "ladder.pcf", _replace_once(pcf, "1000150.0000", "NaN").encode(), None,
         "flag", None),
        ("alignment", "a bore negative", "ladder.pcf",
         _replace_once(pcf, "200000.0000 10000.0000 100.0000", "200000.0000 10000.0000 -100.0000").encode(), None,
         "flag", None),
        ("alignment", "a bore 0", "ladder.pcf",
         _replace_once(pcf, "200000.0000 10000.0000 100.0000", "200000.0000 10000.0000 0").encode(), None,
         "flag", None),
        ("alignment", "an IDF renamed .pcf", "ladder.pcf", _text("examples/polyhedra/two_offices.idf").encode(),
         None, "flag", None),
        ("alignment", "an IFC renamed .pcf", "ladder.pcf", _text("examples/dedup/tunnel_3rings.ifc").encode(), None,
         "flag", None),
        ("alignment", ".json units m over mm values", "ladder.json",
         json.dumps({**json.loads(_text("examples/alignment/ladder.json")), "units": "m"}).encode(), None, "flag",
         None),
        ("alignment", ".json a port position 1e308", "ladder.json", _aligned_json_huge(), None, "flag", None),
        ("alignment", "a perfmap .json", "ladder.json", _text("examples/perfmap/n3_fan_map.json").encode(), None,
         "flag", None),
    ]


def _aligned_json_huge() -> bytes:
    body = json.loads(_text("examples/alignment/ladder.json"))
    body["components"][0]["ports"][0]["position"][0] = 1e308
    return json.dumps(body).encode()


def polyhedra_cases() -> list[Case]:
    idf = _text("examples/polyhedra/two_offices.idf")
    data = ROOT / "tests/solvers/polyhedra/data"
    stl, obj = (data / "ascii_box.stl").read_text(), (data / "revit_room.obj").read_text()
    epjson, gbxml = (data / "openstudio_two_offices.epJSON").read_text(), _text("examples/polyhedra/offices.xml")
    ifc = (data / "ifcopenshell_spaces.ifc").read_text()
    latin = _replace_once(idf, "! Two 5 x 4", "! Büro Zwei 5 x 4")
    objects = re.compile(r"^[A-Za-z][A-Za-z:]*,\s*$")
    ifc_shuffled = _entities_shuffled(ifc)
    vertex = re.search(r"vertex (\S+)", stl).group(1)
    return [
        ("polyhedra", "clean idf", "zones.idf", idf.encode(), None, "same", None),
        ("polyhedra", "cut idf", "zones.idf", _cut(idf), None, "flag", None),
        ("polyhedra", "empty idf", "zones.idf", b"", None, "flag", None),
        ("polyhedra", "shuffled idf objects", "zones.idf", _shuffled_blocks(idf, objects), None, "same", None),
        ("polyhedra", "idf CRLF", "zones.idf", _crlf(idf), None, "same", None),
        ("polyhedra", "idf UTF-16 with BOM", "zones.idf", _utf16(idf), None, "same", None),
        ("polyhedra", "idf Windows-1252 comment", "zones.idf", latin.encode("cp1252"), None, "same", latin.encode()),
        ("polyhedra", "file_units mm on a metre idf", "zones.idf", idf.encode(), {"file_units": "mm"}, "flag", None),
        ("polyhedra", "idf a vertex 1e308", "zones.idf",
         _replace_once(idf, "  5, 4, 0,", "  1e308, 4, 0,").encode(),
         None, "flag", None),
        ("polyhedra", "a PCF renamed .idf", "zones.idf", _text("examples/alignment/ladder.pcf").encode(), None,
         "flag", None),
        ("polyhedra", "clean stl", "box.stl", stl.encode(), None, "same", None),
        ("polyhedra", "cut stl", "box.stl", _cut(stl), None, "flag", None),
        ("polyhedra", "stl CRLF", "box.stl", _crlf(stl), None, "same", None),
        ("polyhedra", "stl UTF-16", "box.stl", _utf16(stl), None, "same", None),
        ("polyhedra", "stl facets shuffled", "box.stl",
         _shuffled_blocks(stl.rstrip("\n"), re.compile(r"^\s*facet"), tail=1), None, "same", None),
        ("polyhedra", "stl a vertex NaN", "box.stl", _replace_once(stl, f"vertex {vertex}", "vertex nan").encode(),
         None, "flag", None),
        ("polyhedra", "stl a vertex 1e308", "box.stl", _replace_once(stl, f"vertex {vertex}", "vertex 1e308").encode(),
         None, "flag", None),
        ("polyhedra", "a tube scan renamed .stl", "box.stl", _text("examples/tube/scan.xyz").encode(), None, "flag",
         None),
        ("polyhedra", "clean obj", "room.obj", obj.encode(), None, "same", None),
        ("polyhedra", "cut obj", "room.obj", _cut(obj), None, "flag", None),
        ("polyhedra", "obj decimal commas", "room.obj", _decimal_commas(obj).encode(), None, "same", None),
        ("polyhedra", "obj a vertex 1e308", "room.obj", re.sub(r"^v \S+", "v 1e308", obj, count=1, flags=re.MULTILINE).encode(),
         None, "flag", None),
        ("polyhedra", "obj units: meter over mm values", "room.obj",
         re.sub(r"^v (\S+) (\S+) (\S+)", lambda m: "v " + " ".join(f"{float(v) * 1000:g}" for v in m.groups()),
                obj, flags=re.MULTILINE).encode(), None, "flag", None),
        ("polyhedra", "an LDraw renamed .obj", "room.obj", _text("examples/rigidity/hinged_wall.ldr").encode(), None,
         "flag", None),
        ("polyhedra", "clean epJSON", "zones.epJSON", epjson.encode(), None, "same", None),
        ("polyhedra", "cut epJSON", "zones.epJSON", _cut(epjson), None, "flag", None),
        ("polyhedra", "epJSON UTF-16", "zones.epJSON", _utf16(epjson), None, "same", None),
        ("polyhedra", "clean gbXML", "offices.xml", gbxml.encode(), None, "same", None),
        ("polyhedra", "cut gbXML", "offices.xml", _cut(gbxml), None, "flag", None),
        ("polyhedra", "gbXML CRLF", "offices.xml", _crlf(gbxml), None, "same", None),
        ("polyhedra", "gbXML lengthUnit Millimeters over metres", "offices.xml",
         gbxml.replace('lengthUnit="Meters"', 'lengthUnit="Millimeters"').encode(), None, "flag", None),
        ("polyhedra", "clean IFC spaces", "spaces.ifc", ifc.encode(), None, "same", None),
        ("polyhedra", "IFC spaces in mm said metres", "spaces.ifc",
         ifc.replace("IFCSIUNIT(*,.LENGTHUNIT.,.MILLI.,.METRE.)", "IFCSIUNIT(*,.LENGTHUNIT.,$,.METRE.)").encode(),
         None, "flag", None),
        ("polyhedra", "cut IFC spaces", "spaces.ifc", _cut(ifc), None, "flag", None),
        ("polyhedra", "IFC spaces shuffled entities", "spaces.ifc", ifc_shuffled.encode(), None, "same", None),
        ("polyhedra", "IFC spaces UTF-16", "spaces.ifc", _utf16(ifc), None, "same", None),
        ("polyhedra", "a dedup IFC (no spaces)", "spaces.ifc", _text("examples/dedup/tunnel_3rings.ifc").encode(),
         None, "flag", None),
        ("polyhedra", "a perfmap CSV renamed .ifc", "spaces.ifc", _text("examples/perfmap/n3_fan_map.csv").encode(),
         None, "flag", None),
    ]


def rigidity_cases() -> list[Case]:
    ldr = _text("examples/rigidity/hinged_wall.ldr")
    parts = [line for line in ldr.splitlines() if line.startswith("1 ")]
    latin = _replace_once(ldr, "0 Author: plantsolve examples", "0 Author: Jürgen Müller")
    mpd = (ROOT / "tests/solvers/rigidity/omr/30023-1-Lighthouse.ldr").read_text(errors="replace")
    tie = (ROOT / "tests/solvers/rigidity/omr/6965-1-TIEIntercep_4h4MXk5.mpd").read_text(errors="replace")
    others = [line for line in ldr.splitlines() if not line.startswith("1 ")]
    shuffled = "\n".join(others[:5] + random.Random(57).sample(parts, len(parts))) + "\n"
    unshuffled = "\n".join(others[:5] + parts) + "\n"
    return [
        ("rigidity", "clean ldr", "wall.ldr", ldr.encode(), None, "same", None),
        ("rigidity", "cut ldr", "wall.ldr", _cut(ldr), None, "flag", None),
        ("rigidity", "empty ldr", "wall.ldr", b"", None, "flag", None),
        ("rigidity", "shuffled part lines", "wall.ldr", shuffled.encode(), None, "same", unshuffled.encode()),
        ("rigidity", "CRLF", "wall.ldr", _crlf(ldr), None, "same", None),
        ("rigidity", "UTF-16 with BOM", "wall.ldr", _utf16(ldr), None, "same", None),
        ("rigidity", "Windows-1252 author", "wall.ldr", latin.encode("cp1252"), None, "same", latin.encode()),
        ("rigidity", "decimal commas", "wall.ldr", _decimal_commas(ldr).encode(), None, "same", None),
        ("rigidity", "a position 1e308", "wall.ldr", _replace_once(ldr, parts[0], parts[0].replace(
            "1 4 0 0 0", "1 4 1e308 0 0")).encode(), None, "flag", None),
        ("rigidity", "a position NaN", "wall.ldr", _replace_once(ldr, parts[0], parts[0].replace(
            "1 4 0 0 0", "1 4 nan 0 0")).encode(), None, "flag", None),
        ("rigidity", "a matrix of zeros", "wall.ldr", _replace_once(ldr, parts[0], parts[0].replace(
            "1 0 0 0 1 0 0 0 1", "0 0 0 0 0 0 0 0 0")).encode(), None, "flag", None),
        ("rigidity", "a PCF renamed .ldr", "wall.ldr", _text("examples/alignment/ladder.pcf").encode(), None,
         "flag", None),
        ("rigidity", "an IFC renamed .ldr", "wall.ldr", _text("examples/dedup/tunnel_3rings.ifc").encode(), None,
         "flag", None),
        ("rigidity", "a tube scan renamed .ldr", "wall.ldr", _text("examples/tube/scan.xyz").encode(), None, "flag",
         None),
        ("rigidity", "clean OMR model", "lighthouse.ldr", mpd.encode(), None, "same", None),
        ("rigidity", "clean .mpd", "tie.mpd", tie.encode(), None, "same", None),
        ("rigidity", "cut .mpd", "tie.mpd", _cut(tie), None, "flag", None),
        ("rigidity", ".mpd CRLF", "tie.mpd", _crlf(tie), None, "same", None),
        ("rigidity", "cut OMR model", "lighthouse.ldr", _cut(mpd), None, "flag", None),
    ]


def _json_edited(body: dict, **changes) -> bytes:
    """``body`` as JSON with each of ``changes`` set (``pipe__radius`` for ``body["pipe"]["radius"]``)."""
    body = json.loads(json.dumps(body))
    for path, value in changes.items():
        node = body
        steps = path.split("__")
        for step in steps[:-1]:
            node = node[step]
        node[steps[-1]] = value
    return json.dumps(body).encode()


def _flowmeter_inputs() -> tuple[dict, str, dict]:
    """The example flowmeter request, its field file's text, and the request with that file for its uniform field."""
    meter = json.loads(_text("examples/flowmeter/meter.json"))
    comsol = _text("examples/flowmeter/magnet_comsol.txt")
    with_file = json.loads(json.dumps(meter))
    with_file.pop("magnetic_field")
    with_file["options"]["magnetic_field_file"] = comsol
    return meter, comsol, with_file


def flowmeter_cases() -> list[Case]:
    meter, comsol, with_file = _flowmeter_inputs()

    def changed(path, value, body=None):
        return _json_edited(body or meter, **{"__".join(path): value})

    data_rows = [i for i, line in enumerate(comsol.splitlines()) if not line.startswith("%")]
    field_lines = comsol.splitlines()
    shuffled_field = field_lines[:data_rows[0]] + random.Random(57).sample(field_lines[data_rows[0]:],
                                                                           len(data_rows))
    in_metres = re.sub(r"(% Length unit:\s*)mm", r"\1m", comsol)
    assert in_metres != comsol
    return [
        ("flowmeter", "clean meter.json", "meter.json", json.dumps(meter).encode(), None, "same", None),
        ("flowmeter", "cut meter.json", "meter.json", _cut(json.dumps(meter, indent=1)), None, "flag", None),
        ("flowmeter", "empty .json", "meter.json", b"", None, "flag", None),
        ("flowmeter", "UTF-16 meter.json", "meter.json", _utf16(json.dumps(meter)), None, "same", None),
        ("flowmeter", "radius negative", "meter.json", changed(("pipe", "radius"), -50.0), None, "flag", None),
        ("flowmeter", "radius 0", "meter.json", changed(("pipe", "radius"), 0.0), None, "flag", None),
        ("flowmeter", "radius 1e308", "meter.json", changed(("pipe", "radius"), 1e308), None, "flag", None),
        ("flowmeter", "radius 50 with units m", "meter.json", changed(("units",), "m"), None, "flag", None),
        ("flowmeter", "magnitude 10 (mT as T)", "meter.json", changed(("magnetic_field", "magnitude"), 10.0), None,
         "flag", None),
        ("flowmeter", "a perfmap .json", "meter.json", _text("examples/perfmap/n3_fan_map.json").encode(), None,
         "flag", None),
        ("flowmeter", "clean field file", "meter.json", json.dumps(with_file).encode(), None, "same", None),
        ("flowmeter", "field file shuffled rows", "meter.json",
         changed(("options", "magnetic_field_file"), "\n".join(shuffled_field) + "\n", with_file), None, "same",
         None),
        ("flowmeter", "field file CRLF", "meter.json",
         changed(("options", "magnetic_field_file"), comsol.replace("\n", "\r\n"), with_file), None, "same", None),
        ("flowmeter", "field file cut", "meter.json",
         changed(("options", "magnetic_field_file"), _cut(comsol).decode(), with_file), None, "flag", None),
        ("flowmeter", "field file decimal commas", "meter.json",
         changed(("options", "magnetic_field_file"), _decimal_commas(comsol), with_file), None, "same", None),
        ("flowmeter", "field file says m, values mm", "meter.json",
         changed(("options", "magnetic_field_file"), in_metres, with_file), None, "flag", None),
        ("flowmeter", "field file (T) holding mT", "meter.json",
         changed(("options", "magnetic_field_file"), _field_in_millitesla(comsol), with_file), None, "flag", None),
        ("flowmeter", "field file a PCF", "meter.json",
         changed(("options", "magnetic_field_file"), _text("examples/alignment/ladder.pcf"), with_file), None,
         "flag", None),
    ]


def _field_in_millitesla(comsol: str) -> str:
    out = []
    for line in comsol.splitlines():
        if line.startswith("%") or not line.strip():
            out.append(line)
            continue
        cells = line.split()
        out.append(" ".join(cells[:3] + [f"{float(c) * 1000:.10g}" for c in cells[3:]]))
    return "\n".join(out) + "\n"


def _instance_twice(ifc: str) -> str:
    lines = ifc.splitlines()
    at = next(k for k, line in enumerate(lines) if line.startswith("#10="))
    return "\n".join(lines[:at + 1] + [lines[at]] + lines[at + 1:]) + "\n"


def _dangling(ifc: str) -> str:
    number = re.search(r"#(\d+)=IFCCARTESIANPOINT", ifc).group(1)
    return ifc.replace(f"#{number}=IFCCARTESIANPOINT", "#999999=IFCCARTESIANPOINT", 1)


def _zipped(name: str, text: str) -> bytes:
    import io
    import zipfile

    out = io.BytesIO()
    with zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as archive:
        archive.writestr(name, text)
    return out.getvalue()


def _entities_shuffled(ifc: str) -> str:
    """An IFC file with its DATA section's lines in another order (an IFC's meaning does not depend on it)."""
    lines = ifc.splitlines()
    data_at = lines.index("DATA;") + 1
    end_at = lines.index("ENDSEC;", data_at)
    entities = lines[data_at:end_at]
    random.Random(57).shuffle(entities)
    return "\n".join(lines[:data_at] + entities + lines[end_at:]) + "\n"


def dedup_cases() -> list[Case]:
    ifc = _text("examples/dedup/zoo_ifc2x3.ifc")
    shuffled = _entities_shuffled(ifc)
    latin = ifc.replace("FILE_DESCRIPTION(", "/* Büro */ FILE_DESCRIPTION(", 1)
    return [
        ("dedup", "clean ifc", "zoo.ifc", ifc.encode(), None, "same", None),
        ("dedup", "cut ifc", "zoo.ifc", _cut(ifc), None, "flag", None),
        ("dedup", "empty ifc", "zoo.ifc", b"", None, "flag", None),
        ("dedup", "shuffled entities", "zoo.ifc", shuffled.encode(), None, "same", None),
        ("dedup", "CRLF", "zoo.ifc", _crlf(ifc), None, "same", None),
        ("dedup", "UTF-16 with BOM", "zoo.ifc", _utf16(ifc), None, "flag", None),
        ("dedup", "Windows-1252 comment", "zoo.ifc", latin.encode("cp1252"), None, "same", latin.encode()),
        ("dedup", "an instance defined twice", "zoo.ifc", _instance_twice(ifc).encode(), None, "flag", None),
        ("dedup", "a point 1e308", "zoo.ifc", re.sub(r"(IFCCARTESIANPOINT\(\()[-0-9.E]+", r"\g<1>1.E308", ifc, count=1
                                                     ).encode(), None, "flag", None),
        ("dedup", "a reference to no instance", "zoo.ifc", _dangling(ifc).encode(), None, "flag", None),
        ("dedup", "schema said IFC4 over IFC2X3", "zoo.ifc",
         ifc.replace("FILE_SCHEMA(('IFC2X3'))", "FILE_SCHEMA(('IFC4'))").encode(), None, "flag", None),
        ("dedup", "an .ifczip holding an empty .ifc", "zoo.ifczip", _zipped("zoo.ifc", ""), None, "flag", None),
        ("dedup", "an .ifczip cut", "zoo.ifczip", _zipped("zoo.ifc", ifc)[:5000], None, "flag", None),
        ("dedup", "a CSV renamed .ifc", "zoo.ifc", _text("examples/perfmap/n3_fan_map.csv").encode(), None, "flag",
         None),
        ("dedup", "a PCF renamed .ifc", "zoo.ifc", _text("examples/alignment/ladder.pcf").encode(), None, "flag",
         None),
        ("dedup", "an LDraw renamed .ifc", "zoo.ifc", _text("examples/rigidity/hinged_wall.ldr").encode(), None,
         "flag", None),
        ("dedup", "tolerance negative", "zoo.ifc", ifc.encode(), {"tolerance": -1}, "flag", None),
        ("dedup", "tolerance 1e308", "zoo.ifc", ifc.encode(), {"tolerance": 1e308}, "flag", None),
    ]


CASES = {"perfmap": perfmap_cases, "tube": tube_cases, "alignment": alignment_cases, "polyhedra": polyhedra_cases,
         "rigidity": rigidity_cases, "flowmeter": flowmeter_cases, "dedup": dedup_cases}
IGNORED_KEYS = ("source", "upload_warnings", "warnings", "notes", "reader", "file_name", "name")


def _canonical(value):
    """The request as order-free data: lists as sorted lists, a reader's notes and row numbers left out."""
    if isinstance(value, dict):
        return {k: _canonical(v) for k, v in sorted(value.items()) if not any(w in k for w in IGNORED_KEYS)}
    if isinstance(value, list):
        items = [_canonical(v) for v in value]
        return sorted(items, key=lambda v: json.dumps(v, sort_keys=True))
    if isinstance(value, float):
        return float(f"{value:.9g}")
    return value


def reading(spec, name: str, data: bytes, options: dict | None, converted=None) -> str | None:
    """A fingerprint of what the kind's reader makes of the file (None when it refuses it); ``converted``, when
    given, turns the request read into what is compared (the values as the solver takes them, say)."""
    import tempfile

    from plantsolve.solvers.base import StoredInput

    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / name
        path.write_bytes(data)
        try:
            request = spec.parse_upload(StoredInput.from_path(path, name), options)
            if converted is not None:
                request = converted(request)
        except Exception:  # noqa: BLE001 - a refusal: the HTTP column says which
            return None
    return hashlib.sha256(json.dumps(_canonical(request.model_dump(mode="json")), sort_keys=True).encode()
                          ).hexdigest()[:12]


def _said(doc: dict) -> str:
    errors = doc.get("errors") or []
    if errors:
        e = errors[0]
        return f"{'.'.join(map(str, e.get('loc', [])))}: {e.get('msg')}"
    return str(doc.get("detail"))


def child(kinds: list[str], only: list[str] | None = None) -> None:
    """In the tree under test: one JSON line per case."""
    import logging
    import tempfile

    logging.disable(logging.WARNING)
    from fastapi.testclient import TestClient

    from plantsolve.app.main import create_app
    from plantsolve.solvers.kinds import load_kinds
    from tests.conftest import service_settings, wait_for

    specs = load_kinds()
    with TestClient(create_app(service_settings(Path(tempfile.mkdtemp())))) as client:
        clean: dict[tuple[str, str], dict] = {}  # (kind, extension) -> the clean file's reading and job

        def job(kind, name, data, options):
            form = {"options": json.dumps(options)} if options else {}
            response = client.post(f"/v1/{kind}/jobs", files={"file": (name, data)}, data=form)
            if response.status_code != 202:
                return response.status_code, None, response.json() if "json" in response.headers.get(
                    "content-type", "") else {"detail": response.text[:200]}
            view = wait_for(client, response.json()["id"], timeout=900)
            return 202, view, {}

        for kind in kinds:
            spec = specs[kind]
            for _, mistake, name, data, options, expect, reference in CASES[kind]():
                if only and not mistake.startswith("clean") and not any(word in mistake for word in only):
                    continue
                ext = Path(name).suffix.lower()
                status, view, doc = job(kind, name, data, options)
                row = {"kind": kind, "mistake": mistake, "status": status}
                if status != 202:
                    said = _said(doc)
                    crash = "it is malformed" in said or status >= 500
                    row.update(outcome=("500" if status >= 500 else "CRASH" if crash else "refused"), said=said)
                else:
                    codes = [w["code"] for w in (view.get("report") or {}).get("warnings") or []]
                    summary = str(view.get("summary") or (view.get("report") or {}).get("message") or "")
                    if mistake.startswith("clean"):
                        clean[(kind, ext)] = {"reading": reading(spec, name, data, options), "codes": set(codes),
                                              "summary": summary}
                    base = clean.get((kind, ext), {"codes": set(), "summary": None, "reading": None})
                    new = sorted(set(codes) - base["codes"])
                    if view["status"] != "succeeded":
                        outcome = f"job {view['status']}" if expect == "same" else f"failed ({view['status']})"
                    elif expect == "same":
                        mine = reading(spec, name, data, options)
                        ref = base["reading"] if reference is None else reading(spec, name, reference, options)
                        if mistake.startswith("clean") or mine == ref:
                            outcome = "same" + (f" +{','.join(new)}" if new else "")
                        else:
                            # a request that keeps the file's text (a field file) differs with its bytes: the
                            # answer is what must not change
                            outcome = "same answer" if summary == base["summary"] else "OTHER READING"
                    else:
                        outcome = f"warned {','.join(new)}" if new else "NO WORD"
                    row.update(outcome=outcome, said=summary if view["status"] == "succeeded" else
                               str((view.get("report") or {}).get("message") or view.get("error") or ""))
                print(json.dumps(row), flush=True)


LOOK = ("500", "CRASH", "NO WORD", "OTHER READING", "job failed")


def _looked_at(rows: list[dict]) -> str:
    counts = ", ".join(f"{w} {sum(r['outcome'].startswith(w) for r in rows)}" for w in LOOK)
    flagged = sum(any(row["outcome"].startswith(w) for w in LOOK) for row in rows)
    return f"{len(rows)} cases, {flagged} to look at ({counts})"


def main() -> None:
    args = table.arguments(__doc__, kinds=CASES).parse_args()
    if args.child:
        sys.path.insert(0, os.getcwd())
        child(args.kinds, args.cases)
        return
    t0 = time.time()
    trees = table.trees(args, __file__)
    table.markdown(trees, ["kind", "mistake", "HTTP", "outcome", "message excerpt"],
                   lambda r: [r["kind"], r["mistake"], str(r["status"]), r["outcome"], table.excerpt(r["said"], 110)],
                   lambda was: f"{was['status']} {was['outcome']}")
    table.counts(trees, _looked_at, t0)


if __name__ == "__main__":
    main()
