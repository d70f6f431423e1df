"""Users' mistakes with perfmap and flowmeter, round 59 (beside bench/trust58_perfflow.py's, not repeated): a per-cent
efficiency without its unit, a pressure column labelled kPa holding ratios, a speed line of one point, an empty or
cut workbook sheet, NaN and 1e300 cells, a whole map of inverse ratios, rows and columns in other orders (CSV,
workbook, GasTurb speed lines), a workbook a few bytes short, another kind's file (IFC, STL, tube scan) sent to
either kind; a flowmeter with probe points outside the pipe, electrodes longer than the liner or a hair long (metres
under mm), a field file of another kind; GasTurb maps with a value lost or added inside a wrapped record; the
GasTurb export of a map in rpm or per cent (GasTurb reads a map's speed as relative), read back by this service; a
GasTurb title whose speed text is free text or contradicted by relative speeds; measured speeds on every row.

Same machinery and outcome classes as bench/trust58_perfflow.py (``same`` / ``flag`` / ``look``; ``WRONG`` is a
confident wrong answer).

    python bench/trust59_perfflow.py [--ref /tmp/base-tree]    # the branch's start beside this tree
"""

from __future__ import annotations

import json
import os
import random
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(Path(__file__).resolve().parent))

import mistakes_table as table  # one BLAS thread, before numpy
import trust58_perfflow as base
from trust57_mistakes import _flowmeter_inputs, _json_edited, _xlsx
from trust58_perfflow import _columns, _speed_csv, _text, _xlsx_cells


def _xlsx_sheets(sheets: dict[str, list[list]]) -> bytes:
    import io

    import openpyxl

    book = openpyxl.Workbook()
    book.remove(book.active)
    for title, rows in sheets.items():
        sheet = book.create_sheet(title)
        for row in rows:
            sheet.append(row)
    out = io.BytesIO()
    book.save(out)
    return out.getvalue()


def _gasturb_line(text: str, line: int, change) -> bytes:
    lines = text.split("\n")
    lines[line - 1] = change(lines[line - 1])
    return "\n".join(lines).encode()


def exports_rows() -> None:
    """In the tree under test: a rig table's speed in rpm, per cent or as a fraction, fitted, exported to GasTurb's
    format and read back by this service's .map reader; one JSON line per case."""
    import logging

    logging.disable(logging.WARNING)
    from plantsolve.solvers.base import StoredInput
    from plantsolve.solvers.perfmap.cycle_exports import gasturb_tables
    from plantsolve.solvers.perfmap.solve import solve
    from plantsolve.solvers.perfmap.upload import parse_upload

    csv = _text("examples/perfmap/n3_fan_map.csv")
    for label, unit, factor in (("speed [rpm]", "rpm", 10000.0), ("speed [%]", "%", 100.0), ("speed [-]", "-", 1.0)):
        table = _speed_csv(csv, unit, factor).encode()
        result = solve(parse_upload(StoredInput.from_bytes("rig.csv", table), {"map": False})).result
        codes = {w.code for w in result.report.warnings}
        (data,) = gasturb_tables(result).values()
        back = parse_upload(StoredInput.from_bytes("back.map", data), {"map": False})
        warned = "exports_speed_not_relative" in codes
        said = "warned exports_speed_not_relative" if warned else "WRONG (no word)" if unit != "-" else "no word"
        read = {w.code for w in back.upload_warnings}
        print(json.dumps({"kind": "perfmap", "mistake": f"GasTurb export of a rig table in {label}",
                          "outcome": f"{said}; read back as {back.setting_units[0]!r}"
                          + ("+implausible_speed" if "implausible_speed" in read else ""),
                          "said": data.decode().splitlines()[0][:100]}), flush=True)


def perfmap_cases() -> list[tuple]:
    csv = _text("examples/perfmap/n3_fan_map.csv")
    lines = csv.splitlines()
    head = "theta,phi,flow,pressure,efficiency"
    per_cent = _columns(csv, lambda h, c: c[:4] + [f"{float(c[4]) * 100:g}"])
    numbers = [[float(c) for c in row.split(",")] for row in lines[1:]]
    speed = _speed_csv(csv)
    speed_rows = speed.splitlines()
    one_point = "\n".join([speed_rows[0], f"12000,{speed_rows[1].split(',', 1)[1]}"] + speed_rows[1:]) + "\n"
    shuffled_rows = "\n".join([lines[0]] + random.Random(59).sample(lines[1:], len(lines) - 1)) + "\n"
    order = [4, 2, 0, 3, 1]
    reordered = "\n".join(",".join(line.split(",")[k] for k in order) for line in lines) + "\n"
    inverse = _columns(csv, lambda h, c: c[:3] + [f"{1 / float(c[3]):.6g}", c[4]])
    kpa_ratios = csv.replace(head, "theta,phi,flow,pressure [kPa],efficiency", 1)
    eff3 = csv.replace(lines[5], ",".join(lines[5].split(",")[:4] + ["3"]), 1)
    nan = csv.replace(lines[5], ",".join(lines[5].split(",")[:3] + ["NaN", lines[5].split(",")[4]]), 1)
    huge = csv.replace(lines[5], ",".join(lines[5].split(",")[:2] + ["1e300"] + lines[5].split(",")[3:]), 1)
    neg_all = _columns(csv, lambda h, c: c[:2] + [f"-{c[2]}"] + c[3:])
    gasturb = (ROOT / "tests/solvers/perfmap/data/gasturb/bigfand.map").read_text()
    compmap = (ROOT / "tests/solvers/perfmap/data/gasturb/compmap.map").read_text()
    cut_sheet = [lines[0].split(",")] + numbers[:-1] + [numbers[-1][:3]]
    xlsx_reordered = [[lines[0].split(",")[k] for k in order]] + [[row[k] for k in order] for row in numbers]
    tube_scan = _text("examples/tube/scan.xyz")
    ifc = _text("examples/dedup/zoo_ifc2x3.ifc")
    stl = ("solid cube\n facet normal 0 0 1\n  outer loop\n   vertex 0 0 1\n   vertex 1 0 1\n   vertex 0 1 1\n"
           "  endloop\n endfacet\nendsolid cube\n")
    measured_speeds = "\n".join([speed_rows[0]] + [f"{float(r.split(',', 1)[0]) + (k % 7) - 3:g},{r.split(',', 1)[1]}"
                                                   for k, r in enumerate(speed_rows[1:])]) + "\n"

    def titled(title: str) -> bytes:
        return "\n".join(["99    " + title] + compmap.split("\n")[1:]).encode()

    return [
        ("perfmap", "clean csv", "map.csv", csv.encode(), None, "same", None),
        ("perfmap", "speed [rpm] measured on every row (each row a setting of its own)", "speed.csv",
         measured_speeds.encode(), None, "flag", None),
        ("perfmap", "GasTurb title 'flow [kg/s], speed [N/Nd]' (a title's free text)", "comp.map",
         titled("Compressor map; flow [kg/s], speed [N/Nd]"), None, "same", titled("Compressor map; flow [kg/s]")),
        ("perfmap", "GasTurb title 'speed [%]' over speeds 0.45..1", "comp.map",
         titled("Compressor map; flow [kg/s], speed [%]"), None, "same", titled("Compressor map; flow [kg/s]")),
        ("perfmap", "efficiency without unit holding per cent", "map.csv", per_cent.encode(), None, "flag", None),
        ("perfmap", "pressure [kPa] holding ratios", "map.csv", kpa_ratios.encode(), None, "flag", None),
        ("perfmap", "a whole map of inverse ratios p1/p2", "map.csv", inverse.encode(), None, "flag", None),
        ("perfmap", "one efficiency of 3", "map.csv", eff3.encode(), None, "flag", None),
        ("perfmap", "a NaN pressure cell", "map.csv", nan.encode(), None, "flag", None),
        ("perfmap", "a flow of 1e300", "map.csv", huge.encode(), None, "flag", None),
        ("perfmap", "every flow negative", "map.csv", neg_all.encode(), None, "flag", None),
        ("perfmap", "rows shuffled", "map.csv", shuffled_rows.encode(), None, "same", csv.encode()),
        ("perfmap", "columns in another order", "map.csv", reordered.encode(), None, "same", csv.encode()),
        ("perfmap", "clean speed csv", "speed.csv", speed.encode(), None, "same", None),
        ("perfmap", "a speed line of one point", "speed.csv", one_point.encode(), None, "flag", None),
        ("perfmap", "clean xlsx", "map.xlsx", _xlsx(lines), None, "same", None),
        ("perfmap", "xlsx columns in another order", "map.xlsx", _xlsx_cells(xlsx_reordered), None, "same",
         _xlsx(lines)),
        ("perfmap", "xlsx an empty first sheet, the table on the second", "map.xlsx",
         _xlsx_sheets({"Notes": [], "Data": [lines[0].split(",")] + numbers}), None, "same", _xlsx(lines)),
        ("perfmap", "xlsx only an empty sheet", "map.xlsx", _xlsx_sheets({"Sheet1": []}), None, "flag", None),
        ("perfmap", "xlsx cut 10 bytes short (inside its zip directory's end record)", "map.xlsx",
         _xlsx(lines)[:-10], None, "flag", None),
        ("perfmap", "xlsx last row cut (two cells missing)", "map.xlsx", _xlsx_cells(cut_sheet), None, "flag", None),
        ("perfmap", "clean GasTurb .map", "fan.map", gasturb.encode(), None, "same", None),
        ("perfmap", "an IFC sent as .csv", "map.csv", ifc.encode(), None, "flag", None),
        ("perfmap", "an IFC sent as .ifc", "map.ifc", ifc.encode(), None, "flag", None),
        ("perfmap", "an ASCII STL sent as .csv", "map.csv", stl.encode(), None, "flag", None),
        ("perfmap", "a tube scan sent as .csv", "map.csv", tube_scan.encode(), None, "flag", None),
        ("perfmap", "a tube scan sent as .xyz", "scan.xyz", tube_scan.encode(), None, "flag", None),
        ("perfmap", "speed [rpm] holding per cent", "speed.csv", _speed_csv(csv, "rpm", 100.0).encode(), None,
         "flag", None),
        ("perfmap", "GasTurb a value lost in line 13 (wrapped record)", "fan.map",
         _gasturb_line(gasturb, 13, lambda line: line.rsplit(None, 1)[0]), None, "flag", None),
        ("perfmap", "GasTurb a value added in line 13 (wrapped record)", "fan.map",
         _gasturb_line(gasturb, 13, lambda line: line + "     16.70000"), None, "flag", None),
        ("perfmap", "GasTurb one record a line, a value lost in line 6", "comp.map",
         _gasturb_line(compmap, 6, lambda line: line.rsplit(None, 1)[0]), None, "flag", None),
    ]


def flowmeter_cases() -> list[tuple]:
    meter, _, with_file = _flowmeter_inputs()

    def request(body=None, **changes) -> bytes:
        return _json_edited(body or meter, **changes)

    ifc = _text("examples/dedup/zoo_ifc2x3.ifc")
    return [
        ("flowmeter", "clean meter.json", "meter.json", json.dumps(meter).encode(), None, "same", None),
        ("flowmeter", "probe points outside the pipe (x 80 mm on R 50)", "meter.json",
         request(options__probe_points=[[0, 0], [80, 0]]), None, "flag", None),
        ("flowmeter", "electrodes longer than the liner", "meter.json",
         request(electrodes__half_length=400.0), None, "flag", None),
        ("flowmeter", "electrode half-angle 0", "meter.json", request(electrodes__half_angle=0.0), None, "flag",
         None),
        ("flowmeter", "electrode half-angle 120 degrees", "meter.json", request(electrodes__half_angle=120.0),
         None, "flag", None),
        ("flowmeter", "liner length 0", "meter.json", request(pipe__liner_length=0.0), None, "flag", None),
        ("flowmeter", "an IFC as the field file", "meter.json",
         request(with_file, options__magnetic_field_file=ifc), None, "flag", None),
        ("flowmeter", "a tube scan as the field file", "meter.json",
         request(with_file, options__magnetic_field_file=_text("examples/tube/scan.xyz")), None, "flag", None),
        ("flowmeter", "a perfmap request as the request", "meter.json",
         _text("examples/perfmap/n3_fan_map.json").encode(), None, "flag", None),
        ("flowmeter", "an IFC as the request", "meter.ifc", ifc.encode(), None, "flag", None),
        ("flowmeter", "velocity samples outside the pipe", "meter.json",
         request(velocity={"type": "samples", "points": [[0, 0], [80, 0], [0, 80], [-80, 0], [0, -80]],
                           "values": [2, 1, 1, 1, 1]}), None, "flag", None),
        ("flowmeter", "patch half-length in metres under mm (0.0157)", "meter.json",
         request(electrodes__half_length=0.0157), None, "flag", None),
        ("flowmeter", "probe point NaN", "meter.json", request(options__probe_points=[[0, 0], ["NaN", 0]]), None,
         "flag", None),
    ]


CASES = {"perfmap": perfmap_cases, "flowmeter": flowmeter_cases}


def main() -> None:
    args = table.arguments(__doc__, kinds=CASES).parse_args()
    if args.child:
        sys.path.insert(0, os.getcwd())
        base.CASES = CASES  # trust58's driver, this round's cases
        base.child(args.kinds, args.cases)
        if "perfmap" in args.kinds and not args.cases:
            exports_rows()
        return
    base.side_by_side(args, __file__)


if __name__ == "__main__":
    main()
