"""The models kinds (polyhedra, rigidity, dedup) given the mistakes trust57's bench does not make, through the real
API (TestClient, jobs run to their end), each judged on the answer's numbers rather than on the reading:

- ``scaled <k>``: a request asking for the same model in another unit: the answer's totals are the clean file's
  times ``k`` (volume k³, floor area k²) and the result names its unit;
- ``same``: the file means what the clean file means (objects, entities or part lines in another order): the same
  totals (volumes, floor areas), the same rigid clusters (as sets of part positions), the same dedup classes;
- ``flag``: a refusal naming the field or line, or a job whose report has a warning the clean file's has not.

The outcome column: ``refused``, ``scaled``/``same``, ``warned <codes>``, and the rows to look at: ``500``,
``CRASH`` (a 422 saying only "malformed"), ``NO WORD`` (a flagged mistake answered with no new warning),
``OTHER ANSWER`` (an invariant mistake answered with other numbers), ``failed`` (accepted, refused after the 202).

    python bench/trust58_models.py [--ref /work/main] [--kinds polyhedra rigidity dedup] [--cases word ...]
    python bench/trust58_models.py --intake-cpu [--ref /work/main]   # dedup's submission check: CPU s, peak RSS
"""

from __future__ import annotations

import json
import os
import random
import re
import subprocess
import sys
import time
from pathlib import Path

import mistakes_table as table  # bench/, the script's folder, is first on sys.path; one BLAS thread

ROOT = Path(__file__).resolve().parent.parent  # the inputs come from this tree, whichever tree reads them
POLY, RIG = ROOT / "tests/solvers/polyhedra/data", ROOT / "tests/solvers/rigidity/omr"
FT = 1 / 0.3048


def _text(path: Path | str) -> str:
    return (ROOT / path).read_text(encoding="utf-8", errors="replace")


def _replace_once(text: str, old: str, new: str) -> str:
    assert old in text, old
    return text.replace(old, new, 1)


def _idf_blocks_shuffled(text: str) -> str:
    """The IDF's objects (from a line that starts an object to its ';') in another order, comments kept with them."""
    objects = re.findall(r"(?:^[ \t]*!.*\n)*^[ \t]*[A-Za-z][^\n!;]*,(?:[^;]*?);[^\n]*\n?", text, flags=re.MULTILINE)
    assert objects, "no objects"
    rest = text
    for o in objects:
        rest = rest.replace(o, "", 1)
    random.Random(58).shuffle(objects)
    return rest + "\n" + "".join(o if o.endswith("\n") else o + "\n" for o in objects)


def _step_entities_shuffled(text: str) -> str:
    lines = text.splitlines()
    data_at = lines.index("DATA;") + 1
    end_at = lines.index("ENDSEC;", data_at)
    entities = lines[data_at:end_at]
    random.Random(58).shuffle(entities)
    return "\n".join(lines[:data_at] + entities + lines[end_at:]) + "\n"


def _without_end(text: str) -> str:
    """The STEP file as a transfer that stopped after the last entity: no ENDSEC, no END-ISO-10303-21."""
    return text[:text.rindex("ENDSEC;")]


def _without_trailer(text: str) -> str:
    """The STEP file with its data section closed but the END-ISO-10303-21 line lost."""
    return text[:text.rindex("END-ISO-10303-21;")]


def _mpd_without(text: str, name: str) -> str:
    """The .mpd without its ``0 FILE <name>`` section (the main model still references it)."""
    sections = re.split(r"(?m)^(?=0 FILE )", text)
    kept = [s for s in sections if not s.lower().startswith(f"0 file {name.lower()}")]
    assert len(kept) == len(sections) - 1, name
    return "".join(kept)


def _ldraw_scaled(text: str, k: float) -> str:
    """Every part line's position times ``k`` (a model written in millimetres, 1 LDU = 0.4 mm)."""
    def scaled(m: re.Match) -> str:
        w = m.group(0).split()
        w[2:5] = [f"{float(v) * k:g}" for v in w[2:5]]
        return " ".join(w)
    return re.sub(r"(?m)^1 .*$", scaled, text)


def _ldraw_parts_shuffled(text: str) -> str:
    """Within each model of the file, its part lines in another order (the headers and FILE lines kept)."""
    out, block = [], []
    rng = random.Random(58)
    for line in text.splitlines():
        if line.startswith("1 "):
            block.append(line)
            continue
        rng.shuffle(block)
        out += block + [line]
        block = []
    rng.shuffle(block)
    return "\n".join(out + block) + "\n"


# (kind, mistake, file name, bytes, options, expect) with expect "same", "flag" or ("scaled", k)
def polyhedra_cases() -> list[tuple]:
    idf = _text("examples/polyhedra/two_offices.idf")
    four = _text(POLY / "4ZoneWithShading_Simple_1.idf")
    gbxml = _text("examples/polyhedra/offices.xml")
    feet_xml = (POLY / "revit_room_feet.xml").read_bytes()
    ifc = _text(POLY / "ifcopenshell_spaces.ifc")
    sqlite_only = "Version,9.6;\n\n  Output:SQLite,\n    SimpleAndTabular;        !- Option Type\n\n" \
                  "  OutputControl:Table:Style,\n    HTML,\n    InchPound;\n"
    ip_tables = idf + "\n  OutputControl:Table:Style,\n    HTML,                    !- Column Separator\n" \
                      "    InchPound;               !- Unit Conversion\n"
    return [
        ("polyhedra", "clean idf", "zones.idf", idf.encode(), None, "same"),
        ("polyhedra", "idf asked for in feet (units ft)", "zones.idf", idf.encode(), {"units": "ft"}, ("scaled", FT)),
        ("polyhedra", "idf asked for in 'feet' (spelled)", "zones.idf", idf.encode(), {"units": "feet"},
         ("scaled", FT)),
        ("polyhedra", "idf asked for in IP (units IP)", "zones.idf", idf.encode(), {"units": "IP"}, "flag"),
        ("polyhedra", "idf said to be in feet (file_units ft) while SI", "zones.idf", idf.encode(),
         {"file_units": "ft"}, "flag"),
        ("polyhedra", "idf asking EnergyPlus for InchPound tables", "zones.idf", ip_tables.encode(), None, "flag"),
        ("polyhedra", "idf of Output:SQLite only", "zones.idf", sqlite_only.encode(), None, "flag"),
        ("polyhedra", "idf objects shuffled (two offices)", "zones.idf", _idf_blocks_shuffled(idf).encode(), None,
         "same"),
        ("polyhedra", "clean idf 4ZoneWithShading", "four.idf", four.encode(), None, "same"),
        ("polyhedra", "idf objects shuffled (4ZoneWithShading)", "four.idf", _idf_blocks_shuffled(four).encode(),
         None, "same"),
        ("polyhedra", "clean gbXML", "offices.xml", gbxml.encode(), None, "same"),
        ("polyhedra", "gbXML lengthUnit Feet over metres", "offices.xml",
         _replace_once(gbxml, 'lengthUnit="Meters"', 'lengthUnit="Feet"').encode(), None, "flag"),
        ("polyhedra", "gbXML lengthUnit Inches over metres", "offices.xml",
         _replace_once(gbxml, 'lengthUnit="Meters"', 'lengthUnit="Inches"').encode(), None, "flag"),
        ("polyhedra", "gbXML asked for in feet", "offices.xml", gbxml.encode(), {"units": "ft"}, ("scaled", FT)),
        ("polyhedra", "clean gbXML in feet (Revit)", "room.xml", feet_xml, None, "same"),
        ("polyhedra", "gbXML in feet said Meters", "room.xml",
         feet_xml.decode("utf-16").replace('lengthUnit="Feet"', 'lengthUnit="Meters"').encode("utf-16"), None,
         "flag"),
        ("polyhedra", "clean IFC spaces", "spaces.ifc", ifc.encode(), None, "same"),
        ("polyhedra", "IFC spaces without ENDSEC/END-ISO", "spaces.ifc", _without_end(ifc).encode(), None, "flag"),
        ("polyhedra", "IFC spaces without END-ISO only", "spaces.ifc", _without_trailer(ifc).encode(), None, "flag"),
        ("polyhedra", "IFC4 spaces headed IFC2X3", "spaces.ifc",
         _replace_once(ifc, "FILE_SCHEMA(('IFC4'))", "FILE_SCHEMA(('IFC2X3'))").encode(), None, "flag"),
        ("polyhedra", "IFC4 spaces headed IFC4X3", "spaces.ifc",
         _replace_once(ifc, "FILE_SCHEMA(('IFC4'))", "FILE_SCHEMA(('IFC4X3'))").encode(), None, "flag"),
        ("polyhedra", "IFC4 spaces headed IFC4X3_ADD2", "spaces.ifc",
         _replace_once(ifc, "FILE_SCHEMA(('IFC4'))", "FILE_SCHEMA(('IFC4X3_ADD2'))").encode(), None, "flag"),
        ("polyhedra", "IFC spaces asked for in feet", "spaces.ifc", ifc.encode(), {"units": "ft"}, ("scaled", FT)),
    ]


def rigidity_cases() -> list[tuple]:
    tie = _text(RIG / "6965-1-TIEIntercep_4h4MXk5.mpd")
    radar = _text(RIG / "889-1-RadarTruck.mpd")
    lighthouse = _text(RIG / "30023-1-Lighthouse.ldr")
    wall = _text("examples/rigidity/hinged_wall.ldr")
    subfiles = re.findall(r"(?m)^0 FILE (.+?)\s*$", radar)
    return [
        ("rigidity", "clean .mpd (radar truck)", "radar.mpd", radar.encode(), None, "same"),
        ("rigidity", f".mpd without its subfile '{subfiles[-1]}'", "radar.mpd",
         _mpd_without(radar, subfiles[-1]).encode(), None, "flag"),
        ("rigidity", ".mpd part lines shuffled (radar truck)", "radar.mpd", _ldraw_parts_shuffled(radar).encode(),
         None, "same"),
        ("rigidity", "clean .mpd (TIE)", "tie.mpd", tie.encode(), None, "same"),
        ("rigidity", ".mpd part lines shuffled (TIE)", "tie.mpd", _ldraw_parts_shuffled(tie).encode(), None, "same"),
        ("rigidity", "clean ldr (lighthouse)", "lighthouse.ldr", lighthouse.encode(), None, "same"),
        ("rigidity", ".ldr part lines shuffled (lighthouse)", "lighthouse.ldr",
         _ldraw_parts_shuffled(lighthouse).encode(), None, "same"),
        ("rigidity", ".ldr in mm (positions x 0.4, lighthouse)", "lighthouse.ldr",
         _ldraw_scaled(lighthouse, 0.4).encode(), None, "flag"),
        ("rigidity", "clean ldr (hinged wall)", "wall.ldr", wall.encode(), None, "same"),
        ("rigidity", ".ldr in mm (positions x 0.4, hinged wall)", "wall.ldr", _ldraw_scaled(wall, 0.4).encode(),
         None, "flag"),
        ("rigidity", ".mpd in mm (positions x 0.4, TIE)", "tie.mpd", _ldraw_scaled(tie, 0.4).encode(), None, "flag"),
    ]


def dedup_cases() -> list[tuple]:
    zoo = _text("examples/dedup/zoo_ifc2x3.ifc")
    tunnel = _text("examples/dedup/tunnel_3rings.ifc")
    schema = re.search(r"FILE_SCHEMA\(\('([^']+)'\)\)", tunnel).group(1)
    other = "IFC2X3" if schema != "IFC2X3" else "IFC4"
    return [
        ("dedup", "clean ifc (zoo)", "zoo.ifc", zoo.encode(), None, "same"),
        ("dedup", "ifc without ENDSEC/END-ISO (zoo)", "zoo.ifc", _without_end(zoo).encode(), None, "flag"),
        ("dedup", "ifc without END-ISO only (zoo)", "zoo.ifc", _without_trailer(zoo).encode(), None, "flag"),
        ("dedup", "IFC2X3 headed IFC4X3 (zoo)", "zoo.ifc",
         _replace_once(zoo, "FILE_SCHEMA(('IFC2X3'))", "FILE_SCHEMA(('IFC4X3'))").encode(), None, "flag"),
        ("dedup", "IFC2X3 headed IFC4X3_ADD2 (zoo)", "zoo.ifc",
         _replace_once(zoo, "FILE_SCHEMA(('IFC2X3'))", "FILE_SCHEMA(('IFC4X3_ADD2'))").encode(), None, "flag"),
        ("dedup", "WCS location 1E308 (zoo)", "zoo.ifc",
         _replace_once(zoo, "#9=IFCCARTESIANPOINT((0.,0.,0.));", "#9=IFCCARTESIANPOINT((1.E308,0.,0.));").encode(),
         None, "flag"),
        ("dedup", "WCS axis of no length (zoo)", "zoo.ifc",
         _replace_once(zoo, "#10=IFCDIRECTION((0.,0.,1.));", "#10=IFCDIRECTION((0.,0.,0.));").encode(), None, "flag"),
        ("dedup", "WCS location 1E9 (zoo, georeferenced)", "zoo.ifc",
         _replace_once(zoo, "#9=IFCCARTESIANPOINT((0.,0.,0.));", "#9=IFCCARTESIANPOINT((1.E9,-2.5E6,30.));").encode(),
         None, "same"),
        ("dedup", "entities shuffled (zoo)", "zoo.ifc", _step_entities_shuffled(zoo).encode(), None, "same"),
        ("dedup", f"clean ifc (tunnel, {schema})", "tunnel.ifc", tunnel.encode(), None, "same"),
        ("dedup", f"{schema} headed {other} (tunnel)", "tunnel.ifc",
         _replace_once(tunnel, f"FILE_SCHEMA(('{schema}'))", f"FILE_SCHEMA(('{other}'))").encode(), None, "flag"),
        ("dedup", "ifc without ENDSEC/END-ISO (tunnel)", "tunnel.ifc", _without_end(tunnel).encode(), None, "flag"),
        ("dedup", "entities shuffled (tunnel)", "tunnel.ifc", _step_entities_shuffled(tunnel).encode(), None, "same"),
    ]


CASES = {"polyhedra": polyhedra_cases, "rigidity": rigidity_cases, "dedup": dedup_cases}


def answer(kind: str, result: dict) -> dict:
    """The numbers of a result the mistakes must keep (or scale)."""
    if kind == "polyhedra":
        return {"units": result["units"], "zones": len(result["zones"]), "volume": result["total_volume"],
                "floor": result["total_floor_area"]}
    if kind == "rigidity":
        at = {p["id"]: tuple(round(v, 3) for v in p.get("position", [])) for p in result.get("parts", [])
              if isinstance(p, dict) and "id" in p}
        clusters = sorted(sorted(str(at.get(i, i)) for i in c) for c in result["clusters"])
        return {"dof": result["dof"], "rigid": result["rigid"], "pieces": len(result.get("pieces") or []),
                "clusters": len(result["clusters"]), "cluster_sizes": sorted(len(c) for c in clusters)}
    return {"classes": sorted(sorted(c.get("members") or []).__len__() for c in result["classes"]),
            "shared": result["products_shared"], "total": result["products_total"]}


def _close(a, b) -> bool:
    if a is None or b is None:
        return a is None and b is None
    return abs(a - b) <= 1e-6 * max(abs(a), abs(b), 1e-9)


def judged(kind: str, expect, mine: dict, clean: dict | None) -> str:
    if clean is None:
        return "no clean answer"
    if isinstance(expect, tuple):
        k = expect[1]
        ok = _close(mine["volume"], None if clean["volume"] is None else clean["volume"] * k ** 3) and \
            _close(mine["floor"], clean["floor"] * k ** 2) and mine["zones"] == clean["zones"]
        return "scaled" if ok else "OTHER ANSWER"
    same = all(_close(mine[k], clean[k]) if isinstance(mine[k], float) or isinstance(clean[k], float)
               else mine[k] == clean[k] for k in mine)  # a sum in another order differs in its last digits
    return "same" if same else "OTHER ANSWER"


def child(kinds: list[str], only: list[str] | None) -> None:
    import logging
    import tempfile

    logging.disable(logging.WARNING)
    from fastapi.testclient import TestClient

    from plantsolve.app.main import create_app
    from tests.conftest import service_settings, wait_for

    with TestClient(create_app(service_settings(Path(tempfile.mkdtemp())))) as client:
        for kind in kinds:
            clean: dict | None = None
            clean_codes: set[str] = set()
            for _, mistake, name, data, options, expect in CASES[kind]():
                if only and not mistake.startswith("clean") and not any(w in mistake for w in only):
                    continue
                form = {"options": json.dumps(options)} if options else {}
                response = client.post(f"/v1/{kind}/jobs", files={"file": (name, data)}, data=form)
                row = {"kind": kind, "mistake": mistake, "status": response.status_code}
                if response.status_code != 202:
                    doc = response.json() if "json" in response.headers.get("content-type", "") else {}
                    errors = doc.get("errors") or [{}]
                    said = f"{'.'.join(map(str, errors[0].get('loc', [])))}: {errors[0].get('msg') or doc.get('detail')}"
                    crash = response.status_code >= 500 or "malformed" in said
                    row.update(outcome="500" if response.status_code >= 500 else "CRASH" if crash else "refused",
                               said=said)
                    print(json.dumps(row), flush=True)
                    continue
                view = wait_for(client, response.json()["id"], timeout=900)
                report = view.get("report") or {}
                codes = {w["code"] for w in report.get("warnings") or []}
                summary = str(view.get("summary") or report.get("message") or view.get("error") or "")
                if view["status"] != "succeeded":
                    row.update(outcome=f"job {view['status']}" if expect == "same" else f"failed ({view['status']})",
                               said=summary)
                    print(json.dumps(row), flush=True)
                    continue
                mine = answer(kind, client.get(f"/v1/jobs/{view['id']}/result").json())
                if mistake.startswith("clean"):
                    clean, clean_codes = mine, codes
                    outcome = "same"
                elif expect == "flag":
                    new = sorted(codes - clean_codes)
                    outcome = f"warned {','.join(new)}" if new else "NO WORD"
                else:
                    outcome = judged(kind, expect, mine, clean)
                row.update(outcome=outcome, said=summary, answer=mine)
                print(json.dumps(row), flush=True)


INTAKE = """
import resource, sys, tempfile, time
from pathlib import Path
from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.dedup import SPEC
text = Path(sys.argv[1]).read_bytes()
filler = b"".join(b"#%d=IFCCARTESIANPOINT((0.,0.,%d.));\\n" % (900000 + k, k) for k in range(int(sys.argv[2])))
text = text.replace(b"DATA;\\n", b"DATA;\\n" + filler, 1)  # points before the products: the whole file is scanned
with tempfile.TemporaryDirectory() as tmp:
    path = Path(tmp) / "big.ifc"
    path.write_bytes(text)
    best = float("inf")
    for _ in range(3):
        source = StoredInput.from_path(path, "big.ifc")
        value = SPEC.input_of(SPEC.parse_upload(source, None), source)
        t0 = time.process_time()
        SPEC.check_input(value)
        best = min(best, time.process_time() - t0)
print(len(text), best, resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024)
"""


def intake_cpu(trees: list[Path], points: int = 1_500_000) -> None:
    """dedup's check at submission on the zoo after ``points`` points (some 60 MB): CPU seconds (least of 3) and the
    process's peak RSS, each tree in turn, twice (interleaved)."""
    print("| tree | file MB | check_input CPU s (least of 3) | peak RSS MB |")
    print("| --- | --- | --- | --- |")
    for _ in range(2):
        for tree in trees:
            done = subprocess.run([sys.executable, "-c", INTAKE, str(ROOT / "examples/dedup/zoo_ifc2x3.ifc"),
                                   str(points)], cwd=tree, capture_output=True, text=True, check=False,
                                  env={**os.environ, "PYTHONPATH": str(tree), "PYTHONDONTWRITEBYTECODE": "1"})
            size, cpu, rss = done.stdout.split()
            print(f"| {tree} | {int(size) / 1e6:.1f} | {float(cpu):.3f} | {float(rss):.0f} |")


def _looked_at(rows: list[dict]) -> str:
    look = ("500", "CRASH", "NO WORD", "OTHER ANSWER", "job ", "failed (")  # failed: refused only after the 202
    return f"{len(rows)} cases, {sum(r['outcome'].startswith(look) for r in rows)} to look at"


def main() -> None:
    parser = table.arguments(__doc__, kinds=CASES)
    parser.add_argument("--intake-cpu", action="store_true", help="dedup's submission check's CPU on a 60 MB model")
    args = parser.parse_args()
    if args.intake_cpu:
        intake_cpu([ROOT] + [Path(ref) for ref in args.ref])
        return
    if args.child:
        sys.path.insert(0, os.getcwd())
        child(args.kinds, args.cases)
        return
    t0 = time.time()
    trees = table.trees(args, __file__)
    table.markdown(trees, ["kind", "mistake", "HTTP", "outcome", "answer / message excerpt"],
                   lambda r: [r["kind"], r["mistake"], str(r["status"]), r["outcome"],
                              table.excerpt((json.dumps(r["answer"]) + " " if "answer" in r else "") + r["said"], 140)],
                   lambda was: f"{was['status']} {was['outcome']}")
    table.counts(trees, _looked_at, t0)


if __name__ == "__main__":
    main()
