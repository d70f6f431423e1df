"""A user's mistakes with each kind's upload route, run through the real API (TestClient, jobs run to their end):
a cut file, another kind's file, an absurd number, a header whose unit contradicts the values, shuffled rows. Prints
one row per case: what the submission answered (a 422 naming a field, or 202) and, for a job, how it ended and the
codes of its report's warnings. A row to look at is a 500, or a job that succeeded without a warning on a mistake.

    python bench/trust54_upload_mistakes.py [--kinds tube perfmap ...]
"""

from __future__ import annotations

import argparse
import json
import os
import random
import sys
import tempfile
from pathlib import Path

for _name in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))


def _text(path: str) -> str:
    return (ROOT / path).read_text()


def _cut(text: str) -> bytes:
    """Cut in the middle of a line, as a transfer that stopped."""
    return text[: len(text) // 2 + 3].encode()


def _shuffled(text: str, keep: int = 0) -> bytes:
    lines = text.splitlines()
    head, body = lines[:keep], lines[keep:]
    random.Random(5).shuffle(body)
    return "\n".join(head + body).encode()


def _absurd(text: str, line: int, old: str, new: str) -> bytes:
    lines = text.splitlines()
    assert old in lines[line], (line, lines[line])
    lines[line] = lines[line].replace(old, new, 1)
    return "\n".join(lines).encode()


def cases() -> list[tuple[str, str, str, bytes, dict | None]]:
    """(case, kind, file name, bytes, options)."""
    xyz, csv, pcf = _text("examples/tube/scan.xyz"), _text("examples/perfmap/n3_fan_map.csv"), \
        _text("examples/alignment/ladder.pcf")
    idf, ldr = _text("examples/polyhedra/two_offices.idf"), _text("examples/rigidity/hinged_wall.ldr")
    comsol = _text("examples/flowmeter/magnet_comsol.txt")
    first_xyz = xyz.splitlines()[0].split()[0]
    first_flow = csv.splitlines()[1].split(",")[2]
    return [
        ("tube: cut .xyz", "tube", "scan.xyz", _cut(xyz), None),
        ("tube: shuffled points", "tube", "scan.xyz", _shuffled(xyz), None),
        ("tube: one coordinate 1e300", "tube", "scan.xyz", _absurd(xyz, 0, first_xyz, "1e300"), None),
        ("tube: header says m, values mm", "tube", "scan.xyz", ("x [m] y [m] z [m]\n" + xyz).encode(), None),
        ("tube: file_units m, values mm", "tube", "scan.xyz", xyz.encode(), {"file_units": "m"}),
        ("tube: a perfmap CSV", "tube", "map.csv", csv.encode(), None),
        ("perfmap: cut .csv", "perfmap", "map.csv", _cut(csv), None),
        ("perfmap: shuffled rows", "perfmap", "map.csv", _shuffled(csv, keep=1), None),
        ("perfmap: one flow 1e300", "perfmap", "map.csv", _absurd(csv, 1, first_flow, "1e300"), None),
        ("perfmap: flow header kg/s", "perfmap", "map.csv",
         csv.replace("flow,", "flow [kg/s],", 1).encode(), None),
        ("perfmap: a tube scan as .csv", "perfmap", "map.csv", xyz.replace(" ", ",").encode(), None),
        ("alignment: cut .pcf", "alignment", "ladder.pcf", _cut(pcf), None),
        ("alignment: UNITS-CO-ORDS INCH, values mm", "alignment", "ladder.pcf",
         pcf.replace("UNITS-CO-ORDS MM", "UNITS-CO-ORDS INCH").encode(), None),
        ("alignment: one END-POINT 1e300", "alignment", "ladder.pcf",
         pcf.replace("1000150.0000", "1e300", 1).encode(), None),
        ("alignment: an IDF renamed .pcf", "alignment", "zones.pcf", idf.encode(), None),
        ("polyhedra: cut .idf", "polyhedra", "zones.idf", _cut(idf), None),
        ("polyhedra: a PCF renamed .idf", "polyhedra", "zones.idf", pcf.encode(), None),
        ("polyhedra: file_units mm on a metre IDF", "polyhedra", "zones.idf", idf.encode(), {"file_units": "mm"}),
        ("rigidity: cut .ldr", "rigidity", "wall.ldr", _cut(ldr), None),
        ("rigidity: shuffled lines", "rigidity", "wall.ldr", _shuffled(ldr), None),
        ("flowmeter: cut field file", "flowmeter", "magnet.txt", _cut(comsol), None),
        ("flowmeter: shuffled field rows", "flowmeter", "magnet.txt",
         _shuffled(comsol, keep=sum(1 for line in comsol.splitlines() if line.startswith("%"))), None),
    ]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--kinds", nargs="*", default=None)
    args = parser.parse_args()
    import logging

    logging.disable(logging.WARNING)
    from fastapi.testclient import TestClient

    from plantsolve.app.main import create_app
    from tests.conftest import service_settings, wait_for

    with TestClient(create_app(service_settings(Path(tempfile.mkdtemp())))) as client:
        print("| case | submission | job | warnings / report |")
        print("| --- | --- | --- | --- |")
        for case, kind, name, data, options in cases():
            if args.kinds and kind not in args.kinds:
                continue
            form = {"options": json.dumps(options)} if options else {}
            response = client.post(f"/v1/{kind}/jobs", files={"file": (name, data)}, data=form)
            if response.status_code != 202:
                errors = response.json().get("errors") or [{}]
                said = f"{'.'.join(map(str, errors[0].get('loc', [])))}: {str(errors[0].get('msg'))[:90]}"
                print(f"| {case} | {response.status_code} | - | {said} |", flush=True)
                continue
            view = wait_for(client, response.json()["id"], timeout=600)
            report = view.get("report") or {}
            codes = [w.get("code") for w in report.get("warnings") or []]
            said = ", ".join(codes) if codes else (report.get("message") or "")[:90]
            print(f"| {case} | 202 | {view['status']} | {said} |", flush=True)


if __name__ == "__main__":
    main()
