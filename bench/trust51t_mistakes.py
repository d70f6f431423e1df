"""The mistakes users make with tube scans and alignment networks, submitted through the real API (TestClient,
embedded thread mode) to this tree and to a reference checkout in the same run; each case is judged against the
known answer:

- ``right``: refused naming the field or line, warned naming the quantity, or solved with the right numbers;
- ``WRONG``: solved without a word with wrong numbers (a confident wrong answer);
- ``REFUSED``: a right input refused (422 or a failed job); ``warned``: a right input answered with other numbers
  and a warning; ``500``: a server error.

A tube's right numbers: the synthetic tube's pipe radius (6 mm, to 5 %), its two bends (90° and 60°, to 2°); an
alignment's: the closed ports of the ladder as written (to 0.01 mm), its cuts.

    python bench/trust51t_mistakes.py [--ref /work/wt/main51t]
"""

from __future__ import annotations

import json
from pathlib import Path

from mistakes_table import (  # bench/, the script's folder, is first on sys.path
    BENCH,
    ROOT,
    child_script,
    compare,
)


TUBE_RADIUS = 6.0
TUBE_ANGLES = (90.0, 60.0)
INCH = 25.4


def tube_points():
    import numpy as np

    from plantsolve.solvers.tube.synthetic import make_model, surface_samples

    model = make_model([(120, 0, 90, 30), (80, 45, 60, 30), (100, 0, 0, 0)], TUBE_RADIUS)
    return surface_samples(model, 4000, np.random.default_rng(0), noise=0.03)


def xyz(pts, fmt="{:.3f} {:.3f} {:.3f}", header=""):
    return (header + "\n".join(fmt.format(*p) for p in pts) + "\n").encode()


def ply_ascii(pts, comments=(), count=None, order="xyz"):
    head = ["ply", "format ascii 1.0", *comments, f"element vertex {len(pts) if count is None else count}",
            *[f"property float {c}" for c in order], "end_header"]
    cols = ["xyz".index(c) for c in order]
    return ("\n".join(head) + "\n" + "\n".join(" ".join(f"{p[k]:.4f}" for k in cols) for p in pts) + "\n").encode()


def ply_binary(pts):
    import numpy as np

    head = (f"ply\nformat binary_little_endian 1.0\nelement vertex {len(pts)}\nproperty float x\nproperty float y\n"
            "property float z\nend_header\n").encode()
    return head + np.asarray(pts, "<f4").tobytes()


def room_ply():
    import numpy as np

    rng = np.random.default_rng(1)
    n = 6000
    face = rng.integers(0, 6, n)
    p = rng.uniform(0, 1, (n, 3)) * [4000, 3000, 2500]
    for k, (axis, value) in enumerate([(0, 0), (0, 4000), (1, 0), (1, 3000), (2, 0), (2, 2500)]):
        p[face == k, axis] = value
    return ply_ascii(p)


def tube_cases():
    import numpy as np

    pts = tube_points()
    rng = np.random.default_rng(5)
    base = xyz(pts)
    lines = base.decode().splitlines()
    shuffled = "\n".join(lines[i] for i in rng.permutation(len(lines))).encode() + b"\n"
    perfmap = ("theta,phi,flow,pressure,efficiency\n" + "\n".join(
        f"{t},{p},{1 + 0.1 * t + 0.01 * p:.4f},{1.5 + 0.02 * p:.4f},{0.8 - 0.001 * t:.4f}"
        for t in range(0, 100, 5) for p in range(0, 100, 5)) + "\n").encode()
    idf = ("Version,9.4;\n\nZone,\n  Office,   !- Name\n  0,        !- Direction of Relative North {deg}\n"
           "  0, 0, 0;  !- X,Y,Z Origin {m}\n\n" + "".join(
               f"BuildingSurface:Detailed,\n  Wall{i},\n  Wall,\n  Construction,\n  Office,\n  Outdoors,\n  ,\n"
               f"  SunExposed,\n  WindExposed,\n  0.5,\n  4,\n  {i},0,3,\n  {i},0,0,\n  {i + 1},0,0,\n  {i + 1},0,3;\n\n"
               for i in range(60))).encode()
    cut_row = base[: len(base) - 9]  # ends in the middle of its last row
    binary = ply_binary(pts)
    big = "\n".join(lines[:100] + ["1e300 0 0"] + lines[100:]).encode() + b"\n"
    nan_text = "\n".join(lines[:100] + ["nan nan nan"] + lines[100:]).encode() + b"\n"
    from plantsolve.solvers.tube.synthetic import make_model, surface_samples

    one_sided = xyz(surface_samples(make_model([(400, 0, 90, 100), (260, 45, 60, 100), (340, 0, 0, 0)], 20.0), 3000,
                                    np.random.default_rng(0), view=np.array([0, 0.3, 1.0]), noise=0.6))
    big_pts = pts * (20.0 / TUBE_RADIUS)  # a 20 mm tube: in inches its radius (0.79) still passes for one in mm
    in_inches = xyz(big_pts / INCH, "{:.5f} {:.5f} {:.5f}")
    ok, flag = "ok", "flag"
    units = ("implausible_pipe_radius", "file_units_assumed")
    radius = ("pipe_radius_disagrees", "implausible_pipe_radius")
    damaged = ("file_truncated", "records_skipped", "records_beyond_header")
    return [
        ("scan.xyz, mm", "scan.xyz", base, {}, ok),
        ("xyz in inches, no unit given", "scan.xyz", xyz(pts / INCH, "{:.5f} {:.5f} {:.5f}"), {}, flag, units),
        ("20 mm tube in inches, no unit given", "scan.xyz", in_inches, {}, flag, units, 20.0),
        ("xyz in inches, file_units in", "scan.xyz", xyz(pts / INCH, "{:.5f} {:.5f} {:.5f}"), {"file_units": "in"}, ok),
        ("xyz in inches, file_units 'Inches'", "scan.xyz", xyz(pts / INCH, "{:.5f} {:.5f} {:.5f}"),
         {"file_units": "Inches"}, ok),
        ("xyz header 'x [m] y [m] z [m]', values in m", "scan.xyz",
         xyz(pts / 1000, "{:.6f} {:.6f} {:.6f}", header="x [m] y [m] z [m]\n"), {}, ok),
        ("20 mm tube, header 'x [in] y [in] z [in]'", "scan.xyz",
         xyz(big_pts / INCH, "{:.5f} {:.5f} {:.5f}", header="x [in] y [in] z [in]\n"), {}, ok, (), 20.0),
        ("20 mm tube, '# units: in' comment", "scan.xyz",
         xyz(big_pts / INCH, "{:.5f} {:.5f} {:.5f}", header="# units: in\n"), {}, ok, (), 20.0),
        ("ply comment units furlong", "scan.ply", ply_ascii(pts / 201168, ["comment units furlong"]), {}, flag, units),
        ("ply comment units um, values in um", "scan.ply", ply_ascii(pts * 1000, ["comment units um"]), {}, ok),
        ("ply comment units yd, values in yd", "scan.ply", ply_ascii(pts / 914.4, ["comment units yd"]), {}, flag,
         units),
        ("20 mm tube ply, comment units dm", "scan.ply", ply_ascii(big_pts / 100, ["comment units dm"]), {}, flag,
         units, 20.0),
        ("ply comment units inch, values in in", "scan.ply", ply_ascii(pts / INCH, ["comment units inch"]), {}, ok),
        ("ply vertex count > rows", "scan.ply", ply_ascii(pts, count=len(pts) + 500), {}, flag, damaged),
        ("ply vertex count < rows", "scan.ply", ply_ascii(pts, count=len(pts) - 500), {}, flag, damaged),
        ("ply properties z x y", "scan.ply", ply_ascii(pts, order="zxy"), {}, ok),
        ("ply binary cut mid element", "scan.ply", binary[: len(binary) - 6], {}, flag, damaged),
        ("xyz cut mid row", "scan.xyz", cut_row, {}, flag, damaged),
        ("perfmap csv as scan", "map.csv", perfmap, {}, flag),
        ("IDF renamed .txt", "model.txt", idf, {}, flag),
        ("ply of a room (mm)", "room.ply", room_ply(), {}, flag),
        ("xyz with a 1e300 row", "scan.xyz", big, {}, flag, damaged),
        ("xyz with a 'nan nan nan' row", "scan.xyz", nan_text, {}, flag, damaged),
        ("pipe_radius -6", "scan.xyz", base, {"pipe_radius": -6}, flag),
        ("tolerance 0", "scan.xyz", base, {"tolerance": 0}, flag),
        ("rows shuffled", "scan.xyz", shuffled, {}, ok),
        ("file pasted twice", "scan.xyz", base + base, {}, flag, ("duplicate_points",)),
        ("pipe_radius '6' (string)", "scan.xyz", base, {"pipe_radius": "6"}, ok),
        ("pipe_radius true", "scan.xyz", base, {"pipe_radius": True}, flag),
        ("tolerance true", "scan.xyz", base, {"tolerance": True}, flag),
        ("pipe_radius '6_0'", "scan.xyz", base, {"pipe_radius": "6_0"}, flag),
        ("pipe_radius 7.8 (1.3x)", "scan.xyz", base, {"pipe_radius": 7.8}, flag, radius),
        ("pipe_radius 6.9 (1.15x)", "scan.xyz", base, {"pipe_radius": 6.9}, flag, radius),
        ("pipe_radius 5.4 (0.9x)", "scan.xyz", base, {"pipe_radius": 5.4}, flag, radius),
        ("pipe_radius 4.6 (0.77x)", "scan.xyz", base, {"pipe_radius": 4.6}, flag, radius),
        ("20 mm tube one side, pipe_radius 23", "scan.xyz", one_sided, {"pipe_radius": 23.0}, flag, radius, 20.0),
        ("20 mm tube one side, pipe_radius 17", "scan.xyz", one_sided, {"pipe_radius": 17.0}, flag, radius, 20.0),
        ("20 mm tube one side, pipe_radius 20", "scan.xyz", one_sided, {"pipe_radius": 20.0}, ok, (), 20.0),
        ("pipe_radius 6.1", "scan.xyz", base, {"pipe_radius": 6.1}, ok),
        ("file_units furlong", "scan.xyz", base, {"file_units": "furlong"}, flag),
        ("units 'Millimeters'", "scan.xyz", base, {"units": "Millimeters"}, ok),
        ("npy in metres, no unit", "scan.npy", _npy(pts / 1000), {}, flag, units),
    ]


def _npy(a):
    import io

    import numpy as np

    buf = io.BytesIO()
    np.save(buf, a)
    return buf.getvalue()


def judge_tube(case, outcome, result):
    """right / WRONG / REFUSED / 500 for one tube outcome: a mistake is answered rightly by a refusal, a failed job
    saying why, the right numbers, or a warning of one of the case's codes (one naming the quantity); a right input
    by the right numbers alone."""
    expect, codes, truth = case
    code, _, view = outcome
    if code >= 500:
        return "500"
    if code == 422 or view["status"] != "succeeded":
        return "REFUSED" if expect == "ok" else "right"
    scale = {"mm": 1.0, "cm": 10.0, "m": 1000.0, "in": INCH, "ft": 304.8}[result["units"]]
    angles = [row["angle"] for row in result["lra"][:-1]]
    right = (abs(result["pipe_radius"] * scale / truth - 1) < 0.03 and len(angles) == 2
             and all(abs(a - b) < 2 for a, b in zip(sorted(angles), sorted(TUBE_ANGLES))))
    if right:
        return "right"
    warned = [w["code"] for w in result["report"]["warnings"]]
    if expect == "ok":  # a right input answered wrongly: confidently, or with a warning
        return "warned" if warned else "WRONG"
    return "right" if any(c in codes for c in warned) else "WRONG"


def alignment_cases():
    import random

    pcf = Path(ROOT, "examples", "alignment", "ladder.pcf").read_text()
    body = json.loads(Path(ROOT, "examples", "alignment", "ladder.json").read_text())
    head, *blocks = _pcf_blocks(pcf)
    rnd = random.Random(3)
    shuffled_blocks = blocks[:]
    rnd.shuffle(shuffled_blocks)
    lines = pcf.splitlines(keepends=True)
    cut_at = next(i for i in range(len(lines) - 1, 0, -1) if lines[i].startswith("    END-POINT")
                  and lines[i - 1].startswith("    COMPONENT-IDENTIFIER"))
    in_inches = _scale_pcf(pcf, 1 / INCH).replace("UNITS-CO-ORDS MM", "UNITS-CO-ORDS INCH").replace(
        "UNITS-BORE MM", "UNITS-BORE INCH")
    nan_body = json.loads(json.dumps(body))
    nan_body["components"][3]["ports"][0]["position"][0] = "NaN"
    big_body = json.loads(json.dumps(body))
    big_body["components"][3]["ports"][0]["position"][0] = 1e300
    neg_body = json.loads(json.dumps(body))
    neg_body["components"][3]["radius"] = -50
    shuffled_body = json.loads(json.dumps(body))
    rnd.shuffle(shuffled_body["components"])
    rnd.shuffle(shuffled_body["connections"])
    ok, flag = "ok", "flag"
    fixed = {"fixed_components": ["N0-0"]}
    return [
        ("ladder.pcf", "ladder.pcf", pcf.encode(), fixed, ok),
        ("UNITS-CO-ORDS INCH over mm values", "ladder.pcf", pcf.replace("UNITS-CO-ORDS MM", "UNITS-CO-ORDS INCH")
         .encode(), fixed, flag),
        ("UNITS-CO-ORDS M over mm values", "ladder.pcf", pcf.replace("UNITS-CO-ORDS MM", "UNITS-CO-ORDS M")
         .encode(), fixed, flag),
        ("UNITS-BORE INCH over mm bores", "ladder.pcf", pcf.replace("UNITS-BORE MM", "UNITS-BORE INCH").encode(),
         fixed, flag),
        ("both INCH over mm values", "ladder.pcf", pcf.replace("UNITS-CO-ORDS MM", "UNITS-CO-ORDS INCH")
         .replace("UNITS-BORE MM", "UNITS-BORE INCH").encode(), fixed, flag),
        ("a file in inches, said so", "ladder.pcf", in_inches.encode(), fixed, ok),
        ("cut inside a component", "ladder.pcf", "".join(lines[:cut_at + 1]).encode(), fixed, flag),
        ("cut mid line", "ladder.pcf", pcf[: pcf.rindex("END-POINT") + 30].encode(), fixed, flag),
        ("components reordered", "ladder.pcf", (head + "".join(shuffled_blocks)).encode(), fixed, ok),
        ("file pasted twice", "ladder.pcf", (pcf + "".join(blocks)).encode(), fixed, flag),
        ("position_tolerance '1' (string)", "ladder.pcf", pcf.encode(), {**fixed, "position_tolerance": "1"}, ok),
        ("position_tolerance true", "ladder.pcf", pcf.encode(), {**fixed, "position_tolerance": True}, flag),
        ("position_tolerance 0", "ladder.pcf", pcf.encode(), {**fixed, "position_tolerance": 0}, flag),
        ("angle_tolerance true", "ladder.pcf", pcf.encode(), {**fixed, "angle_tolerance": True}, flag),
        ("perfmap csv as .pcf", "map.pcf", b"theta,phi,flow,pressure,efficiency\n0,0,1,1.5,0.8\n5,0,1.5,1.5,0.79\n",
         {}, flag),
        ("IDF as .pcf", "model.pcf", b"Version,9.4;\nZone,\n  Office,\n  0,\n  0, 0, 0;\n", {}, flag),
        ("ladder.json", "ladder.json", json.dumps(body).encode(), {}, ok),
        ("json NaN text coordinate", "ladder.json", json.dumps(nan_body).encode(), {}, flag),
        ("json 1e300 coordinate", "ladder.json", json.dumps(big_body).encode(), {}, flag),
        ("json negative radius", "ladder.json", json.dumps(neg_body).encode(), {}, flag),
        ("json shuffled", "ladder.json", json.dumps(shuffled_body).encode(), {}, ok),
        ("json units 'Millimetres'", "ladder.json", json.dumps({**body, "units": "Millimetres"}).encode(), {}, ok),
        ("json units 'Mm'", "ladder.json", json.dumps({**body, "units": "Mm"}).encode(), {}, flag),
        ("json units furlong", "ladder.json", json.dumps({**body, "units": "furlong"}).encode(), {}, flag),
        ("UNITS-BORE FURLONG", "ladder.pcf", pcf.replace("UNITS-BORE MM", "UNITS-BORE FURLONG").encode(), fixed,
         flag),
        ("UNITS-BORE mm (lower case)", "ladder.pcf", pcf.replace("UNITS-BORE MM", "UNITS-BORE mm").encode(), fixed,
         ok),
        ("a bore of 1e300", "ladder.pcf", pcf.replace("10000.0000 100.0000", "10000.0000 1e300", 1).encode(), fixed,
         flag),
        ("pipe_stiffness '1_0'", "ladder.pcf", pcf.encode(), {**fixed, "pipe_stiffness": "1_0"}, flag),
    ]


def _pcf_blocks(text):
    """The header, then each top-level item's lines (a keyword at column 0 starts one)."""
    out, cur = [], []
    for line in text.splitlines(keepends=True):
        if line[:1].strip() and cur and any(not ln[:1].isspace() for ln in cur[:1]) and line.split()[0] in {
                "ELBOW", "TEE", "PIPE", "VALVE", "FLANGE", "BEND", "REDUCER-CONCENTRIC", "CAP", "OLET"}:
            out.append("".join(cur))
            cur = []
        cur.append(line)
    out.append("".join(cur))
    return out


def _scale_pcf(text, factor):
    out = []
    for line in text.splitlines(keepends=True):
        words = line.split()
        if words and words[0] in ("END-POINT", "CENTRE-POINT", "BRANCH1-POINT"):
            nums = [f"{float(w) * factor:.6f}" for w in words[1:]]
            line = "    " + " ".join([words[0], *nums]) + "\n"
        out.append(line)
    return "".join(out)


def judge_alignment(case_expect, outcome, result, reference):
    code, _, view = outcome
    if code >= 500:
        return "500"
    if code == 422 or view["status"] != "succeeded":
        return "REFUSED" if case_expect == "ok" else "right"
    warned = bool(result["report"]["warnings"])
    if reference is None:
        return "right"
    scale = {"mm": 1.0, "cm": 10.0, "m": 1000.0, "in": INCH, "ft": 304.8}[result["units"]]
    ports = {c["id"]: [p["position"] for p in c["ports"]] for c in result["components"]}
    ref = reference
    common = [k for k in ref if k in ports]
    worst = max((max(abs(a * scale - b) for pa, pb in zip(ports[k], ref[k]) for a, b in zip(pa, pb))
                 for k in common), default=float("inf"))
    right = len(common) == len(ref) == len(ports) and worst < 0.01 and not result["cut_connections"]
    if right:
        return "right"
    if case_expect == "ok":
        return "warned" if warned else "WRONG"
    return "right" if warned else "WRONG"


CHILD = child_script("trust51t_mistakes", r"""
if __name__ == "__main__":
    tmp = pathlib.Path(tempfile.mkdtemp())
    with TestClient(create_app(service_settings(tmp))) as c:
        reference = None
        for kind, cases in (("tube", m.tube_cases()), ("alignment", m.alignment_cases())):
            for name, filename, data, options, expect, *more in cases:
                t0 = time.process_time()
                outcome, res = submit(c, kind, filename, data, options, 240)
                if kind == "tube":
                    codes = more[0] if more else ()
                    truth = more[1] if len(more) > 1 else m.TUBE_RADIUS
                    verdict = m.judge_tube((expect, codes, truth), outcome, res)
                else:
                    if name == "ladder.pcf" and res:
                        reference = {k["id"]: [p["position"] for p in k["ports"]] for k in res["components"]}
                    verdict = m.judge_alignment(expect, outcome, res, reference)
                code, refusal, view = outcome
                said = refusal or ""
                if res is not None:
                    said = ",".join(w["code"] for w in res["report"]["warnings"]) or "ok"
                    if kind == "tube":
                        said += f" r={res['pipe_radius']:.3g}{res['units']} bends={len(res['lra']) - 1}"
                elif view is not None:
                    said = "failed: " + (view.get("summary") or view.get("error") or "")[:160]
                print(json.dumps({"kind": kind, "case": name, "verdict": verdict, "code": code, "said": said}), flush=True)
""")


def main() -> None:
    compare(__doc__.split("\n\n")[0], CHILD, ROOT, BENCH, width=44)


if __name__ == "__main__":
    main()
