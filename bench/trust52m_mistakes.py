"""The mistakes users make with flow meters, zone models and IFC models for dedup, submitted through the real API
(TestClient, embedded thread mode) to this tree and to a reference checkout in the same run; each case is judged
against what the input means:

- ``right``: refused naming the field or line, warned naming the quantity, or solved with the right numbers and no
  false alarm;
- ``WRONG``: solved without a word with wrong numbers, or with an option silently unused (a confident wrong answer);
- ``REFUSED``: a right input refused (422 or a failed job); ``warned``: a right input answered with a false alarm;
  ``500``: a server error.

    python bench/trust52m_mistakes.py [--ref /work/wt/main52m] [--verbose]
"""

from __future__ import annotations

import json
import os
import random

from mistakes_table import (  # bench/, the script's folder, is first on sys.path
    BENCH,
    ROOT,
    child_script,
    compare,
)

METRES_PER = {"m": 1.0, "mm": 1e-3, "ft": 0.3048, "in": 0.0254}


def _read(path: str) -> bytes:
    with open(os.path.join(ROOT, path), "rb") as f:
        return f.read()


def _meter(**electrodes) -> bytes:
    body = json.loads(_read("examples/flowmeter/meter.json"))
    body["electrodes"] = electrodes
    return json.dumps(body).encode()


def flowmeter_cases():
    """(name, filename, data, options, expect); expect: ("refuse", field) | ("clean", forbidden codes)."""
    comsol = _read("examples/flowmeter/magnet_comsol.txt").decode()
    meter = json.loads(_read("examples/flowmeter/meter.json"))
    meter.pop("magnetic_field")
    return [
        ("patch electrodes (example)", "meter.json", _read("examples/flowmeter/meter.json"), None, ("clean", ())),
        ("point electrodes, no half_angle", "m.json", _meter(shape="point"), None, ("clean", ())),
        ("point electrodes with half_angle 30", "m.json", _meter(shape="point", half_angle=30.0), None,
         ("refuse", "half_angle")),
        ("button electrodes with half_angle 22.5", "m.json", _meter(shape="button", radius=5.0, half_angle=22.5),
         None, ("refuse", "half_angle")),
        ("patch with button radius", "m.json", _meter(shape="patch", half_angle=22.5, radius=5.0), None,
         ("refuse", "radius")),
        ("IDF text as the field file", "m.json", json.dumps(meter).encode(),
         {"magnetic_field_file": _read("examples/polyhedra/two_offices.idf").decode()},
         ("refuse", "magnetic_field_file")),
        ("COMSOL field file cut mid-row", "m.json", json.dumps(meter).encode(),
         {"magnetic_field_file": comsol[: comsol.rstrip().rfind(" ")]}, ("refuse", "magnetic_field_file")),
        ("COMSOL field file, rows shuffled", "m.json", json.dumps(meter).encode(),
         {"magnetic_field_file": _shuffled_rows(comsol)}, ("clean", ())),
    ]


def _shuffled_rows(text: str) -> str:
    lines = text.splitlines()
    head = [line for line in lines if line.startswith("%")]
    rows = [line for line in lines if line.strip() and not line.startswith("%")]
    random.Random(5).shuffle(rows)
    return "\n".join(head + rows) + "\n"


def polyhedra_cases():
    idf = _read("tests/solvers/polyhedra/data/openstudio_two_offices.idf").decode()
    objects = idf.split(";")
    body, tail = objects[:-1], objects[-1]
    shuffled = body[:]
    random.Random(3).shuffle(shuffled)
    return [
        ("IDF as exported", "m.idf", idf.encode(), None, ("clean", ("truncated_file",))),
        ("IDF ending on ';' without a line ending", "m.idf", idf.rstrip().encode(), None,
         ("clean", ("truncated_file",))),
        ("IDF with a comment after the last ';', cut", "m.idf", (idf.rstrip() + "\n! Zone, Office 3").encode(), None,
         ("warn", "truncated_file")),
        ("IDF cut inside an object", "m.idf", idf[: idf.rfind(",", 0, len(idf) - 200)].encode(), None,
         ("warn", "truncated_file")),
        ("IDF objects shuffled", "m.idf", (";".join(shuffled) + ";" + tail).encode(), None, ("clean", ())),
        ("IFC space without a body: message names it", "m.ifc",
         _read("tests/solvers/polyhedra/data/ifcopenshell_spaces.ifc"), None, ("names", "IfcSpace '104'")),
        ("IFC assigning MILLIMETRE and FOOT", "m.ifc", _two_ifc_units("(#2,#3,#4,#9001)"), None,
         ("refuse", "2 length units")),
        ("IFC assigning FOOT and MILLIMETRE", "m.ifc", _two_ifc_units("(#9001,#3,#4,#2)"), None,
         ("refuse", "2 length units")),
        ("JSON body in m with options.file_units ft", None,
         json.dumps({**json.loads(_read("examples/polyhedra/gable_house.json")), "options": {"file_units": "ft"}}).encode(),
         None, ("refuse", "file_units")),
        ("JSON upload with options.file_units ft", "house.json", _read("examples/polyhedra/gable_house.json"),
         {"file_units": "ft"}, ("clean", ())),
        ("SketchUp OBJ in inches (header says so)", "room.obj", _sketchup_box("inches", 0.0254), None,
         ("volume", 30.0)),
        ("SketchUp OBJ in feet (header says so)", "room.obj", _sketchup_box("feet", 0.3048), None, ("volume", 30.0)),
        ("SketchUp OBJ in meters", "room.obj", _sketchup_box("meters", 1.0), None, ("volume", 30.0)),
        ("gbXML named .idf", "m.idf", _read("examples/polyhedra/offices.xml"), None, ("refuse", "file")),
    ]


def _sketchup_box(word: str, size: float) -> bytes:
    """A 3 x 4 x 2.5 m room as SketchUp exports it in ``word`` (``size`` m each)."""
    a, b, c = 3 / size, 4 / size, 2.5 / size
    points = [(x, y, z) for x in (0, a) for y in (0, b) for z in (0, c)]
    quads = ((1, 2, 4, 3), (5, 7, 8, 6), (1, 5, 6, 2), (3, 4, 8, 7), (1, 3, 7, 5), (2, 6, 8, 4))
    return ("# Alias OBJ Model File\n# Exported from SketchUp, (c) 2000-2012 Trimble Navigation Limited\n"
            f"# File units = {word}\n\no room\n" + "".join(f"v {x:.6f} {y:.6f} {z:.6f}\n" for x, y, z in points)
            + "".join("f " + " ".join(map(str, q)) + "\n" for q in quads)).encode()


def _two_ifc_units(units: str) -> bytes:
    text = _read("tests/solvers/polyhedra/data/ifcopenshell_spaces.ifc").decode()
    foot = ("#9001=IFCCONVERSIONBASEDUNIT(#9002,.LENGTHUNIT.,'FOOT',#9003);\n"
            "#9002=IFCDIMENSIONALEXPONENTS(1,0,0,0,0,0,0);\n"
            "#9003=IFCMEASUREWITHUNIT(IFCLENGTHMEASURE(0.3048),#9004);\n#9004=IFCSIUNIT(*,.LENGTHUNIT.,$,.METRE.);")
    return text.replace("#5=IFCUNITASSIGNMENT((#2,#3,#4));", f"#5=IFCUNITASSIGNMENT({units});\n{foot}").encode()


def _ifc(model) -> bytes:
    return model.to_string().encode()


def _with_unit(model, name: str):
    import ifcopenshell.api

    (unit,) = [u for u in model.by_type("IfcSIUnit") if u.UnitType == "LENGTHUNIT"]
    assignment = model.by_type("IfcUnitAssignment")[0]
    new = ifcopenshell.api.run("unit.add_conversion_based_unit", model, name=name)
    assignment.Units = [u for u in assignment.Units if u != unit] + [new]
    return model


def _two_units(model, name: str | None):
    """A second length unit beside the project's: a conversion-based ``name``, or (None) the same SI unit again
    (the project's made MILLI METRE)."""
    import ifcopenshell.api

    (unit,) = [u for u in model.by_type("IfcSIUnit") if u.UnitType == "LENGTHUNIT"]
    assignment = model.by_type("IfcUnitAssignment")[0]
    if name is None:
        unit.Prefix = "MILLI"
        second = model.createIfcSIUnit(None, "LENGTHUNIT", "MILLI", "METRE")
    else:
        second = ifcopenshell.api.run("unit.add_conversion_based_unit", model, name=name)
    assignment.Units = [*assignment.Units, second]
    return model


def _factor(model, name: str, metres: float):
    model = _with_unit(model, name)
    model.by_type("IfcConversionBasedUnit")[0].ConversionFactor.ValueComponent = model.create_entity("IfcReal", metres)
    return model


def _house(scale: float = 1.0):
    from plantsolve.solvers.dedup.synthetic import ModelSpec, Product, build_model

    doors = [Product("Door", entity="IfcDoor", extrusion=(0.9 * scale, 0.05 * scale, 2.1 * scale), name=f"D{k}")
             for k in range(4)]
    walls = [Product("Wall", entity="IfcWall", extrusion=(5.0 * scale, 0.2 * scale, 3.0 * scale), name=f"W{k}")
             for k in range(3)]
    return build_model(ModelSpec(products=doors + walls))


def _plant(scale: float = 1.0):
    """Six 5 cm pipes 1 - 3 m long and three valves: no door, wall or storey to judge the unit by."""
    from plantsolve.solvers.dedup.synthetic import ModelSpec, Product, build_model

    pipes = [Product("Pipe", entity="IfcFlowSegment", extrusion=(0.05 * scale, 0.05 * scale, (1 + k % 3) * scale),
                     name=f"P{k}") for k in range(6)]
    valves = [Product("Valve", entity="IfcFlowController", extrusion=(0.2 * scale, 0.1 * scale, 0.1 * scale),
                      name=f"V{k}") for k in range(3)]
    return build_model(ModelSpec(products=pipes + valves))


def _shuffled_entities(text: bytes) -> bytes:
    lines = text.decode().split("\n")
    start = lines.index("DATA;") + 1
    end = lines.index("ENDSEC;", start)
    data = lines[start:end]
    random.Random(7).shuffle(data)
    return "\n".join(lines[:start] + data + lines[end:]).encode()


def dedup_cases():
    zoo = _read("examples/dedup/zoo_ifc2x3.ifc")
    return [
        ("zoo as given", "zoo.ifc", zoo, None, ("clean", ())),
        ("zoo, entity lines shuffled", "zoo.ifc", _shuffled_entities(zoo), None, ("same_as", "zoo as given")),
        ("house in m, unit says FOOT", "h.ifc", _ifc(_with_unit(_house(), "foot")), None,
         ("warn", "implausible_product_size")),
        ("house in mm, unit says INCH", "h.ifc", _ifc(_with_unit(_house(1000.0), "inch")), None,
         ("warn", "implausible_product_size")),
        ("house in ft, unit says FOOT", "h.ifc", _ifc(_with_unit(_house(1 / 0.3048), "foot")), None,
         ("clean", ("implausible_product_size",))),
        ("plant in m, unit says FOOT", "p.ifc", _ifc(_with_unit(_plant(), "foot")), None,
         ("warn", "implausible_product_size")),
        ("plant in mm, unit says INCH", "p.ifc", _ifc(_with_unit(_plant(1000.0), "inch")), None,
         ("warn", "implausible_product_size")),
        ("house in m, METRE and FOOT both assigned", "h.ifc", _ifc(_two_units(_house(), "foot")), None,
         ("refuse", "2 length units")),
        ("house in mm, MILLI METRE listed twice", "h.ifc", _ifc(_two_units(_house(1000.0), None)), None,
         ("units", "mm")),
        ("house in ft, an INCH with a foot's factor", "h.ifc", _ifc(_factor(_house(1 / 0.3048), "inch", 0.3048)),
         None, ("warn", "length_unit_factor_differs")),
        ("IDF named .ifc", "m.ifc", _read("examples/polyhedra/two_offices.idf"), None, ("refuse", "file")),
        ("zoo cut in half", "zoo.ifc", zoo[: len(zoo) // 2], None, ("warn", "truncated_file")),
    ]


def judge(expect, outcome, result, results_by_name) -> str:
    code, refusal, view = outcome
    if code >= 500 or (view is not None and view["status"] == "failed" and "Traceback" in json.dumps(view)):
        return "500"
    how, what = expect
    codes = [w["code"] for w in result["report"]["warnings"]] if result else []
    if how == "refuse":
        if code == 422 or code == 415:
            return "right" if what in (refusal or "") else "refused?"
        if result is None and view is not None and what in json.dumps(view):
            return "right"  # refused by the solve: a failed job naming it
        if any(c.startswith("implausible_") for c in codes):
            return "right"  # not refused, but warned naming the quantity
        return "WRONG" if result is not None else "failed"
    if how == "warn":
        if code in (415, 422) or what in codes:
            return "right"
        return "WRONG" if result is not None else "failed"
    if result is None:
        return "REFUSED"
    if how == "volume":
        if abs(result["total_volume"] - what) <= 1e-3 * what:
            return "right"
        return "right" if any(c.startswith("implausible_") for c in codes) else "WRONG"
    if how == "units":
        right = result["units"] == what and abs(result["metres_per_unit"] - METRES_PER[what]) < 1e-9 * METRES_PER[what]
        return "right" if right and not any(c.startswith("implausible_") for c in codes) else "WRONG"
    if how == "names":
        return "right" if any(what in w["message"] for w in result["report"]["warnings"]) else "WRONG"
    if how == "same_as":
        other = results_by_name.get(what)
        if other is None:
            return "-"
        key = (lambda r: sorted(len(c.get("members", [])) for c in r.get("classes", [])))
        return "right" if key(other) == key(result) else "WRONG"
    return "warned" if any(c in codes for c in what) else "right"


CHILD = child_script("trust52m_mistakes", r"""
if __name__ == "__main__":
    tmp = pathlib.Path(tempfile.mkdtemp())
    with TestClient(create_app(service_settings(tmp))) as c:
        for kind, cases in (("flowmeter", m.flowmeter_cases()), ("polyhedra", m.polyhedra_cases()),
                            ("dedup", m.dedup_cases())):
            by_name = {}
            for name, filename, data, options, expect in cases:
                outcome, res = submit(c, kind, filename, data, options)
                by_name[name] = res
                verdict = m.judge(expect, outcome, res, by_name)
                code, refusal, view = outcome
                said = refusal or ""
                if res is not None:
                    said = ",".join(w["code"] for w in res["report"]["warnings"]) or "ok"
                    if kind == "flowmeter":
                        said += f" S={res['sensitivity']:.5f}"
                    if kind == "dedup":
                        said += f" units={res['units']}"
                elif view is not None:
                    said = "failed: " + (view.get("summary") or view.get("error") or "")[:160]
                print(json.dumps({"kind": kind, "case": name, "verdict": verdict, "code": code, "said": said}),
                      flush=True)
""")


def main() -> None:
    compare(__doc__.split("\n\n")[0], CHILD, ROOT, BENCH, width=50)


if __name__ == "__main__":
    main()
