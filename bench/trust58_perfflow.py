"""A new round of users' mistakes with perfmap and flowmeter files, sent through the real API (TestClient, jobs run to
their end), beside bench/trust57_mistakes.py's (not repeated here): a per-cent column holding fractions under other
spellings and the reverse, a header unit its values contradict, a table cut at its end, duplicated speed lines,
another kind's file, absurd numbers in maps and request files, a GasTurb map with a Reynolds correction, an XLSX
formula without its cached value, a sheet of text, units spelled as users spell them; a flowmeter field file
without its units, or in a unit its values contradict, its columns in another order, cut in its last row, electrode
angles in radians.

Each case expects one of:

- ``same``: the file means what a reference file means (the clean one, or one spelling the unit as the reader's
  tables do): read to the same request (lists compared as sets), or for flowmeter the same answer;
- ``flag``: a refusal naming the field or line, or a job whose report has a warning the clean file's has not;
- ``look``: shown as it comes out (a mistake the file alone cannot tell: rad/s in an rpm column).

Outcome column: ``422 <loc>`` (refused, where it says), ``warned <codes>``, ``right`` (a ``same`` case read the same),
``WRONG`` (a ``flag`` case that succeeded without a new warning, or a ``same`` case read to other numbers), ``500``.

    python bench/trust58_perfflow.py [--ref /tmp/base-tree]    # the branch's start beside this tree
"""

from __future__ import annotations

import io
import json
import os
import random
import re
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent  # the inputs come from this tree, whichever tree reads them
sys.path.insert(0, str(Path(__file__).resolve().parent))

import mistakes_table as table  # one BLAS thread, before numpy
from trust57_mistakes import (
    _flowmeter_inputs,
    _json_edited,
    _said,
    _utf16,
    _xlsx,
)
from trust57_mistakes import reading as trust57_reading


def _text(path: str) -> str:
    return (ROOT / path).read_text(encoding="utf-8")


def _columns(text: str, mapping) -> str:
    """The CSV with each row's cells passed through ``mapping(header, cells) -> cells``."""
    lines = text.splitlines()
    header = lines[0].split(",")
    return "\n".join([lines[0]] + [",".join(mapping(header, row.split(","))) for row in lines[1:]]) + "\n"


def _speed_csv(csv: str, unit: str = "rpm", factor: float = 10000.0) -> str:
    """The fan map's speed lines of theta 0 as a one-setting table: phi (relative speed) times ``factor``."""
    rows = [r.split(",") for r in csv.splitlines()[1:]]
    out = [f"speed [{unit}],flow [lbm/s],pressure ratio,efficiency"]
    out += [f"{float(r[1]) * factor:g},{r[2]},{r[3]},{r[4]}" for r in rows if float(r[0]) == 0.0]
    return "\n".join(out) + "\n"


def _xlsx_cells(rows: list[list]) -> bytes:
    import openpyxl

    book = openpyxl.Workbook()
    for row in rows:
        book.active.append(row)
    out = io.BytesIO()
    book.save(out)
    return out.getvalue()


def _gasturb_values(text: str, table: str, value) -> str:
    """The map with the first value of the first speed row of ``table`` replaced by ``value(old)``."""
    lines = text.split("\n")
    at = lines.index(table)
    row = next(k for k in range(at + 1, len(lines)) if lines[k].split()[:1] == ["0.20000"])
    tokens = lines[row].split()
    lines[row] = lines[row].replace(tokens[1], value(tokens[1]), 1)
    return "\n".join(lines)


def perfmap_cases() -> list[tuple]:
    csv = _text("examples/perfmap/n3_fan_map.csv")
    lines = csv.splitlines()
    gasturb = (ROOT / "tests/solvers/perfmap/data/gasturb/bigfand.map").read_text()
    as_json = json.loads(_text("examples/perfmap/n3_fan_map.json"))
    frac = lambda header: csv.replace("theta,phi,flow,pressure,efficiency", header, 1)
    per_cent = _columns(csv, lambda h, c: c[:4] + [f"{float(c[4]) * 100:g}"])
    speed = _speed_csv(csv)
    speed_rows = speed.splitlines()
    body = speed_rows[1:]
    last_speed = [r for r in body if r.startswith(body[-1].split(",")[0] + ",")]
    shuffled_json = json.loads(json.dumps(as_json))
    random.Random(58).shuffle(shuffled_json["positions"])
    for p in shuffled_json["positions"]:
        order = list(range(len(p["flow"])))
        random.Random(58).shuffle(order)
        for key in ("flow", "pressure", "efficiency"):
            p[key] = [p[key][k] for k in order]
    lines_09 = [r for r in body if r.startswith("9000,")]
    pasted = "\n".join([speed_rows[0]] + [r for r in body if not r.startswith("9500,")]
                       + [r.replace("9000,", "9500,", 1) for r in lines_09]) + "\n"
    doubled = speed + "\n".join(lines_09) + "\n"
    negative_pr = lines[1].split(",")
    eff7_json = json.loads(json.dumps(as_json))
    eff7_json["positions"][0]["efficiency"][2] = 7
    neg_pr_json = json.loads(json.dumps(as_json))
    neg_pr_json["positions"][0]["pressure"][2] = -1.0799
    reynolds = gasturb.replace("Reynolds: RNI=0.1 f=1 RNI=1 f=1", "Reynolds: RNI=0.1 f=0.92 RNI=1 f=1", 1)
    assert reynolds != gasturb
    no_reynolds = gasturb.replace("Reynolds: RNI=0.1 f=1 RNI=1 f=1\n", "", 1)
    header_rows = [c for c in lines[0].split(",")]
    numbers = [[float(c) for c in row.split(",")] for row in lines[1:]]
    formula = [header_rows] + [row[:4] + ([f"=0.5+0*{row[4]}"] if k == 3 else [row[4]])
                               for k, row in enumerate(numbers)]
    text_sheet = [["Prüfstand 3", "Kennfeld"], ["siehe Blatt 2", "Messung vom 3.11."], ["Bemerkung", "ok"]]
    spelled = {
        "flow [kg/sec]": "flow [kg/s]", "flow [lbm/sec]": "flow [lbm/s]", "flow [lb/s]": "flow [lbm/s]",
        "flow [kg s^-1]": "flow [kg/s]", "flow (kg/s)": "flow [kg/s]", "flow [m3/hr]": "flow [m3/h]",
        "flow [m^3/h]": "flow [m3/h]", "flow [l/min]": "flow [L/min]", "pressure [kPa(a)]": "pressure [kPa]",
        "pressure [bara]": "pressure [bar]", "pressure [psia]": "pressure [psi]",
        "efficiency [percent]": "efficiency [%]", "efficiency [pct]": "efficiency [%]",
        "flow [kg/s.]": "flow [kg/s]", "flow [pps]": "flow [lbm/s]", "flow [Kg/S]": "flow [kg/s]",
        "pressure [mbar]": "pressure [mbar]", "flow [lbs/sec]": "flow [lbm/s]",
    }
    cases = [
        ("perfmap", "clean csv", "map.csv", csv.encode(), None, "same", None),
        ("perfmap", "eta [%] holding fractions", "map.csv", frac("theta,phi,flow,pressure,eta [%]").encode(), None,
         "flag", None),
        ("perfmap", "Eff. (%) holding fractions", "map.csv", frac("theta,phi,flow,pressure,Eff. (%)").encode(), None,
         "flag", None),
        ("perfmap", "η [%] holding fractions", "map.csv", frac("theta,phi,flow,pressure,η [%]").encode(), None,
         "flag", None),
        ("perfmap", "eta [-] holding per cent", "map.csv",
         per_cent.replace("efficiency", "eta [-]", 1).encode(), None, "flag", None),
        ("perfmap", "efficiency [1] holding per cent", "map.csv",
         per_cent.replace("efficiency", "efficiency [1]", 1).encode(), None, "flag", None),
        ("perfmap", "clean speed csv", "speed.csv", speed.encode(), None, "same", None),
        ("perfmap", "speed [rpm] holding rad/s", "speed.csv",
         _speed_csv(csv, "rpm", 10000 * 2 * 3.141592653589793 / 60).encode(), None, "look", None),
        ("perfmap", "speed [rad/s] holding rpm", "speed.csv", _speed_csv(csv, "rad/s").encode(), None, "look", None),
        ("perfmap", "speed [1/s] holding rpm", "speed.csv", _speed_csv(csv, "1/s").encode(), None, "look", None),
        ("perfmap", "corrected speed [%] holding rpm", "speed.csv",
         _speed_csv(csv, "%").replace("speed [%]", "corrected speed [%]").encode(), None, "flag", None),
        ("perfmap", "physical speed [rpm] holding relative speeds", "speed.csv",
         _speed_csv(csv, "rpm", 1.0).replace("speed [rpm]", "N [rpm]").encode(), None, "flag", None),
        ("perfmap", "cut: last row short a cell", "speed.csv",
         (speed.rstrip("\n").rsplit(",", 1)[0]).encode(), None, "flag", None),
        ("perfmap", "cut: last cell cut mid-number", "speed.csv", speed.rstrip("\n")[:-2].encode(), None, "flag",
         None),
        ("perfmap", "cut: last cell cut to '0.'", "speed.csv",
         re.sub(r"[0-9]+$", "", speed.rstrip("\n")).encode(), None, "flag", None),
        ("perfmap", "cut: the last speed line's last rows gone", "speed.csv",
         "\n".join(speed_rows[:-(len(last_speed) - 2)]).encode(), None, "look", None),
        ("perfmap", "clean .json", "map.json", json.dumps(as_json).encode(), None, "same", None),
        ("perfmap", "shuffled .json positions and points", "map.json", json.dumps(shuffled_json).encode(), None,
         "same", json.dumps(as_json).encode()),
        ("perfmap", "a speed line pasted twice (same rows)", "speed.csv", doubled.encode(), None, "flag", None),
        ("perfmap", "a speed line pasted under the next speed", "speed.csv", pasted.encode(), None, "flag", None),
        ("perfmap", "a flowmeter request .json", "map.json", _text("examples/flowmeter/meter.json").encode(), None,
         "flag", None),
        ("perfmap", "a COMSOL field file renamed .csv", "map.csv", _text("examples/flowmeter/magnet_comsol.txt")
         .encode(), None, "flag", None),
        ("perfmap", "a GasTurb turbine map", "turb.map",
         (ROOT / "tests/solvers/perfmap/data/gasturb/turbimap.map").read_bytes(), None, "flag", None),
        ("perfmap", "a GasTurb map renamed .csv", "map.csv", gasturb.encode(), None, "flag", None),
        ("perfmap", "a pyCycle map renamed .csv", "map.csv",
         (ROOT / "tests/solvers/perfmap/data/pycycle_fan_map.py").read_bytes(), None, "flag", None),
        ("perfmap", "pressure ratio negative (csv)", "map.csv",
         csv.replace(lines[1], ",".join(negative_pr[:3] + ["-" + negative_pr[3], negative_pr[4]]), 1).encode(),
         None, "flag", None),
        ("perfmap", "efficiency 7 (.json)", "map.json", json.dumps(eff7_json).encode(), None, "flag", None),
        ("perfmap", "pressure negative (.json)", "map.json", json.dumps(neg_pr_json).encode(), None, "flag", None),
        ("perfmap", "zero flow at 66 % efficiency", "map.csv",
         csv.replace(lines[1], ",".join(lines[1].split(",")[:2] + ["0"] + lines[1].split(",")[3:]), 1).encode(),
         None, "flag", None),
        ("perfmap", "clean GasTurb .map", "fan.map", gasturb.encode(), None, "same", None),
        ("perfmap", "GasTurb efficiency 7", "fan.map", _gasturb_values(gasturb, "Efficiency", lambda v: "7.00000").encode(),
         None, "flag", None),
        ("perfmap", "GasTurb pressure ratio negative", "fan.map",
         _gasturb_values(gasturb, "Pressure Ratio", lambda v: "-" + v).encode(), None, "flag", None),
        ("perfmap", "GasTurb with a Reynolds correction f 0.92", "fan.map", reynolds.encode(), None, "flag", None),
        ("perfmap", "GasTurb without its Reynolds line", "fan.map", no_reynolds.encode(), None, "same",
         gasturb.encode()),
        ("perfmap", "GasTurb UTF-16, Reynolds f 0.92", "fan.map", _utf16(reynolds), None, "flag", None),
        ("perfmap", "clean xlsx", "map.xlsx", _xlsx(lines), None, "same", None),
        ("perfmap", "xlsx a formula without its cached value", "map.xlsx", _xlsx_cells(formula), None, "flag", None),
        ("perfmap", "xlsx a sheet of text", "map.xlsx", _xlsx_cells(text_sheet), None, "flag", None),
    ]
    for said, canonical in spelled.items():
        quantity = said.split()[0].split("(")[0]
        header = {"flow": "theta,phi,{},pressure,efficiency", "pressure": "theta,phi,flow,{},efficiency",
                  "efficiency": "theta,phi,flow,pressure,{}"}[quantity]
        source = per_cent if quantity == "efficiency" else csv
        user = source.replace("theta,phi,flow,pressure,efficiency", header.format(said), 1)
        ours = source.replace("theta,phi,flow,pressure,efficiency", header.format(canonical), 1)
        si = "m3/s" if "m3" in canonical or "L/" in canonical else {"flow": "kg/s", "pressure": "kPa"}.get(quantity)
        converted = {"result_units": {quantity: si}} \
            if quantity != "efficiency" else None  # the values compared in SI: the spellings mean the same
        cases.append(("perfmap", f"units as users spell them: {said}", "map.csv", user.encode(), converted, "same",
                      ours.encode()))
    return cases


def flowmeter_cases() -> list[tuple]:
    meter, comsol, with_file = _flowmeter_inputs()

    def request(body=None, **changes) -> bytes:
        return _json_edited(body or meter, **changes)

    no_length = re.sub(r"% Length unit:.*\n", "", comsol)
    no_tesla = comsol.replace(" (T)", "")
    neither = re.sub(r"% Length unit:.*\n", "", no_tesla)
    in_metres_no_unit = "\n".join(
        line if line.startswith("%") else " ".join([f"{float(c) / 1000:g}" for c in line.split()[:3]]
                                                   + line.split()[3:])
        for line in no_length.splitlines()) + "\n"
    header = next(line for line in comsol.splitlines() if line.startswith("% x"))
    data = [line for line in comsol.splitlines() if not line.startswith("%")]
    heads = [h for h in re.split(r"\s{2,}", header[1:].strip())]
    order = [0, 1, 2, 4, 3, 5]
    swapped = "\n".join([line for line in comsol.splitlines() if line.startswith("%") and line != header]
                        + ["% " + "   ".join(heads[k] for k in order)]
                        + ["   ".join(line.split()[k] for k in order) for line in data]) + "\n"
    mt_header_t_values = comsol.replace("(T)", "(mT)")
    last_short = comsol.rstrip("\n").rsplit(None, 1)[0]
    with_radians = json.loads(json.dumps(meter))
    with_radians["electrodes"]["half_angle"] = 0.3927
    return [
        ("flowmeter", "clean meter.json", "meter.json", json.dumps(meter).encode(), None, "same", None),
        ("flowmeter", "clean field file", "meter.json", request(with_file), None, "same", None),
        ("flowmeter", "field file without its length unit", "meter.json",
         request(with_file, options__magnetic_field_file=no_length), None, "same", None),
        ("flowmeter", "field file without its field unit", "meter.json",
         request(with_file, options__magnetic_field_file=no_tesla), None, "same", None),
        ("flowmeter", "field file without any unit", "meter.json",
         request(with_file, options__magnetic_field_file=neither), None, "same", None),
        ("flowmeter", "field file in m, no unit, request in mm", "meter.json",
         request(with_file, options__magnetic_field_file=in_metres_no_unit), None, "flag", None),
        ("flowmeter", "field file header (mT) over tesla values", "meter.json",
         request(with_file, options__magnetic_field_file=mt_header_t_values), None, "flag", None),
        ("flowmeter", "field file Bx and By columns swapped with their headers", "meter.json",
         request(with_file, options__magnetic_field_file=swapped), None, "same", None),
        ("flowmeter", "field file cut in its last row", "meter.json",
         request(with_file, options__magnetic_field_file=last_short), None, "flag", None),
        ("flowmeter", "field file cut mid-number (no newline)", "meter.json",
         request(with_file, options__magnetic_field_file=comsol.rstrip("\n")[:-4]), None, "flag", None),
        ("flowmeter", "radius 0.05 with units mm (metres)", "meter.json", request(pipe__radius=0.05,
                                                                                 pipe__liner_length=0.3,
                                                                                 electrodes__half_length=0.0157),
         None, "flag", None),
        ("flowmeter", "uniform field 10 mT written as 10 (T)", "meter.json",
         request(magnetic_field__magnitude=10.0), None, "flag", None),
        ("flowmeter", "electrode half-angle in radians (0.3927)", "meter.json", json.dumps(with_radians).encode(),
         None, "flag", None),
        ("flowmeter", "a perfmap CSV as the field file", "meter.json",
         request(with_file, options__magnetic_field_file=_text("examples/perfmap/n3_fan_map.csv")), None, "flag",
         None),
        ("flowmeter", "a GasTurb map as the request", "meter.json",
         (ROOT / "tests/solvers/perfmap/data/gasturb/bigfand.map").read_bytes(), None, "flag", None),
    ]


CASES = {"perfmap": perfmap_cases, "flowmeter": flowmeter_cases}


def _in_solver_units(request):
    """The values as the solver takes them, converted (a request with ``result_units``)."""
    from plantsolve.solvers.perfmap.validation import load

    return load(request).internal.model_copy(update={"units": None, "source": None})


def reading(spec, name: str, data: bytes, options: dict | None) -> str | None:
    """What the kind's reader makes of the file, order-free (None when it refuses it); with ``result_units``, the
    values as the solver takes them."""
    return trust57_reading(spec, name, data, options,
                           _in_solver_units if (options or {}).get("result_units") else None)


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
        clean: dict[tuple[str, str], dict] = {}

        def job(kind, name, data, options):
            form = {"options": json.dumps(options)} if options else {}
            response = client.post(f"/v1/{kind}/jobs", files={"file": (name, data)}, data=form)
            if response.status_code != 202:
                return response.status_code, None, response.json() if "json" in response.headers.get(
                    "content-type", "") else {"detail": response.text[:200]}
            return 202, wait_for(client, response.json()["id"], timeout=900), {}

        def answer(view) -> str:
            return str(view.get("summary") or (view.get("report") or {}).get("message") or "")

        for kind in kinds:
            spec = specs[kind]
            for _, mistake, name, data, options, expect, reference in CASES[kind]():
                if only and not mistake.startswith("clean") and not any(word in mistake for word in only):
                    continue
                if kind == "perfmap":  # the reading is what is judged, not the map over the settings
                    options = {"map": False, **(options or {})}
                status, view, doc = job(kind, name, data, options)
                row = {"kind": kind, "mistake": mistake, "status": status}
                if status != 202:
                    errors = doc.get("errors") or []
                    loc = ".".join(map(str, errors[0].get("loc", []))) if errors else ""
                    said = _said(doc)
                    row.update(outcome="500" if status >= 500 else f"422 {loc}" if
                               "it is malformed" not in said else "CRASH", said=said)
                    print(json.dumps(row), flush=True)
                    continue
                codes = [w["code"] for w in (view.get("report") or {}).get("warnings") or []]
                if mistake.startswith("clean"):
                    clean[(kind, Path(name).suffix, name)] = {"codes": set(codes), "answer": answer(view),
                                                              "reading": reading(spec, name, data, options)}
                base = clean.get((kind, Path(name).suffix, name)) or next(
                    (v for k, v in clean.items() if k[:2] == (kind, Path(name).suffix)), None) or {
                    "codes": set(), "answer": None, "reading": None}
                new = sorted(set(codes) - base["codes"])
                if view["status"] != "succeeded":
                    outcome = f"job {view['status']}"
                elif mistake.startswith("clean"):
                    outcome = "right"
                elif expect == "same":
                    if kind == "flowmeter":
                        same = answer(view) == base["answer"] if reference is None else None
                    else:
                        ref = base["reading"] if reference is None else reading(spec, name, reference, options)
                        same = reading(spec, name, data, options) == ref
                    outcome = ("right" if same else "WRONG (other numbers)") + (f" +{','.join(new)}" if new else "")
                elif expect == "flag":
                    outcome = f"warned {','.join(new)}" if new else "WRONG (no word)"
                else:
                    outcome = f"warned {','.join(new)}" if new else "no word"
                row.update(outcome=outcome, said=answer(view) if view["status"] == "succeeded" else
                           str((view.get("report") or {}).get("message") or view.get("error") or ""))
                print(json.dumps(row), flush=True)


def _failed(rows: list[dict]) -> str:
    bad = [r for r in rows if r["outcome"].startswith(("WRONG", "500", "CRASH", "job"))]
    return f"{len(rows)} cases, {len(bad)} WRONG/500/CRASH/failed"


def side_by_side(args, script: str) -> None:
    """The table of ``script``'s rows (this bench's, or trust59_perfflow's) in each tree."""
    t0 = time.time()
    trees = table.trees(args, script)
    table.markdown(trees, ["kind", "case", "after", "message excerpt"],
                   lambda r: [r["kind"], r["mistake"], r["outcome"], table.excerpt(r["said"], 100)],
                   lambda was: was["outcome"])
    table.counts(trees, _failed, t0)


def main() -> None:
    args = table.arguments(__doc__, kinds=CASES).parse_args()
    if args.child:
        sys.path.insert(0, os.getcwd())
        child(args.kinds, args.cases)
        return
    side_by_side(args, __file__)


if __name__ == "__main__":
    main()
