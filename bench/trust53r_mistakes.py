"""The mistakes users make with the tube, PCF and perfmap readers that trust51t/trust52m left: micrometres in text
scans, a scan in inches read in the assumed millimetres, an NPY of more than three columns, a PCF's UNITS records
over a file in the other unit, a pyCycle map's speeds in per cent, a table cut inside its last number; submitted
through the real API (TestClient, embedded thread mode) to this tree and to a reference checkout in the same run.

- ``right``: refused naming the field or line, warned naming the quantity, or solved with the right numbers (and,
  where the case says so, the warning that says what was read);
- ``WRONG``: solved without a word with wrong numbers, or without the word the case needs;
- ``REFUSED``: a right input refused (422 or a failed job); ``warned``: a right input answered with a false alarm;
  ``500``: a server error.

A tube's right numbers: the synthetic tube's pipe radius (to 3 %) and its two bends (90° and 60°, to 2°); an
alignment's: the ladder's closed ports as written (to 0.01 mm); a map's: no false alarm.

    python bench/trust53r_mistakes.py [--ref /work/wt/main53r] [--verbose]
"""

from __future__ import annotations

import re
from pathlib import Path

from mistakes_table import (  # bench/, the script's folder, is first on sys.path
    BENCH,
    ROOT,
    child_script,
    compare,
)
from trust51t_mistakes import (
    INCH,
    TUBE_RADIUS,
    _npy,
    _scale_pcf,
    judge_alignment,  # noqa: F401 - the child calls it as m.judge_alignment
    judge_tube,
    tube_points,
    xyz,
)


def tube_cases():
    """(name, filename, data, options, (expect, codes, truth)); expect: ok (right numbers), flag (a refusal or one
    of ``codes``), note (right numbers and one of ``codes``)."""
    import numpy as np

    pts = tube_points()
    big = pts * (20.0 / TUBE_RADIUS)
    um = "{:.1f} {:.1f} {:.1f}"
    numbered = np.column_stack([np.arange(len(pts)), pts])
    intensity = np.column_stack([pts, np.random.default_rng(2).uniform(0, 255, len(pts))])
    units = ("file_units_assumed", "implausible_pipe_radius")
    return [
        ("xyz in um, '# units: um'", "scan.xyz", xyz(pts * 1000, um, header="# units: um\n"), {}, ("ok", (), 6.0)),
        ("xyz in um, header 'x [µm] y [µm] z [µm]'", "scan.xyz",
         xyz(pts * 1000, um, header="x [µm] y [µm] z [µm]\n"), {}, ("ok", (), 6.0)),
        ("csv in um, header x_um,y_um,z_um", "scan.csv",
         xyz(pts * 1000, "{:.1f},{:.1f},{:.1f}", header="x_um,y_um,z_um\n"), {}, ("ok", (), 6.0)),
        ("xyz in um, file_units 'microns'", "scan.xyz", xyz(pts * 1000, um), {"file_units": "microns"},
         ("ok", (), 6.0)),
        ("20 mm tube in inches, no unit given", "scan.xyz", xyz(big / INCH, "{:.5f} {:.5f} {:.5f}"), {},
         ("flag", units, 20.0)),
        ("20 mm tube in inches, pipe_radius 20 (mm)", "scan.xyz", xyz(big / INCH, "{:.5f} {:.5f} {:.5f}"),
         {"pipe_radius": 20.0}, ("flag", units, 20.0)),
        ("20 mm tube in mm, no unit given", "scan.xyz", xyz(big), {}, ("ok", (), 20.0)),
        ("6 mm tube in mm, no unit given", "scan.xyz", xyz(pts), {}, ("ok", (), 6.0)),
        ("npy x y z intensity", "scan.npy", _npy(intensity), {}, ("note", ("npy_columns_dropped",), 6.0)),
        ("npy row number, x, y, z", "scan.npy", _npy(numbered), {}, ("flag", ("npy_columns_dropped",), 6.0)),
        ("npy x y z", "scan.npy", _npy(pts), {}, ("ok", (), 6.0)),
    ]


def judge_tube_case(case, outcome, result):
    expect, codes, truth = case
    if expect != "note":
        return judge_tube(case, outcome, result)
    verdict = judge_tube(("ok", codes, truth), outcome, result)
    if verdict != "right":
        return verdict
    return "right" if any(w["code"] in codes for w in result["report"]["warnings"]) else "WRONG"


def alignment_cases():
    pcf = Path(ROOT, "examples", "alignment", "ladder.pcf").read_text()
    fixed = {"fixed_components": ["N0-0"]}
    both = pcf.replace("UNITS-CO-ORDS MM", "UNITS-CO-ORDS INCH").replace("UNITS-BORE MM", "UNITS-BORE INCH")
    in_inches = _scale_pcf(pcf, 1 / INCH).replace("UNITS-CO-ORDS MM", "UNITS-CO-ORDS INCH").replace(
        "UNITS-BORE MM", "UNITS-BORE INCH")
    nps = re.sub(r" 100\.0000$", " 4.0000", in_inches, flags=re.M)  # DN 100 is NPS 4
    return [
        ("ladder.pcf", "ladder.pcf", pcf.encode(), fixed, "ok"),
        ("both INCH over a mm file", "ladder.pcf", both.encode(), fixed, "flag"),
        ("CO-ORDS INCH, no UNITS-BORE, over a mm file", "ladder.pcf",
         pcf.replace("UNITS-BORE MM\n", "").replace("UNITS-CO-ORDS MM", "UNITS-CO-ORDS INCH").encode(), fixed, "flag"),
        ("a file in inches with NPS bores, said so", "ladder.pcf", nps.encode(), fixed, "ok"),
        ("UNITS-BORE MM over NPS bores", "ladder.pcf", re.sub(r" 100\.0000$", " 4.0000", pcf, flags=re.M).encode(),
         fixed, "flag"),
    ]


def perfmap_cases():
    """(name, filename, data, options, (expect, codes)); expect: clean (none of ``codes``) or warn (one of them)."""
    ncp01 = Path(ROOT, "tests", "solvers", "perfmap", "data", "pycycle", "ncp01.py").read_text()
    percent = re.sub(r"NCP01\.NcMap = np\.array\(\[([^\]]*)\]\)", lambda m: "NCP01.NcMap = np.array([" + ",".join(
        f"{100 * float(v):g}" for v in m.group(1).split(",")) + "])", ncp01)
    table = _map_table()
    flagged = ("implausible_speed", "truncated_file")
    return [
        ("pyCycle ncp01.py", "ncp01.py", ncp01.encode(), None, ("clean", flagged)),
        ("pyCycle NcMap in per cent", "ncp01.py", percent.encode(), None, ("warn", ("implausible_speed",))),
        ("csv, last efficiency cut to 2 decimals", "map.csv", table[:-2].encode(), None,
         ("warn", ("truncated_file",))),
        ("csv, whole, no final line ending", "map.csv", table.encode(), None, ("clean", flagged)),
        ("n3_fan_map.csv", "n3_fan_map.csv", Path(ROOT, "examples", "perfmap", "n3_fan_map.csv").read_bytes(), None,
         ("clean", flagged)),
    ]


def _map_table() -> str:
    """Three speed lines of 4-decimal efficiencies, one printed short (a trailing zero dropped), the last 0.8163."""
    import numpy as np

    rng = np.random.default_rng(3)
    lines = ["speed,flow [kg/s],pressure ratio,efficiency"]
    for i, (phi, k) in enumerate((phi, k) for phi in (0.6, 0.8, 1.0) for k in range(10)):
        eff = 0.80 + 0.01 * k - 0.001 * k * k + rng.uniform(0.0001, 0.0099)
        cell = f"{eff:.2f}" if i == 4 else f"{eff:.4f}".rstrip("0")
        lines.append(f"{phi},{10 + 2 * k + 5 * phi:.3f},{1.2 + 0.05 * k * phi:.4f},{cell}")
    lines[-1] = lines[-1].rsplit(",", 1)[0] + ",0.8163"
    return "\n".join(lines)


def judge_perfmap(expect, outcome, result):
    how, codes = expect
    code, _, view = outcome
    if code >= 500:
        return "500"
    if code in (415, 422) or view["status"] != "succeeded":
        return "right" if how == "warn" else "REFUSED"
    warned = [w["code"] for w in result["report"]["warnings"]]
    if how == "warn":
        return "right" if any(c in warned for c in codes) else "WRONG"
    return "warned" if any(c in warned for c in codes) else "right"


CHILD = child_script("trust53r_mistakes", r"""
if __name__ == "__main__":
    tmp = pathlib.Path(tempfile.mkdtemp())
    with TestClient(create_app(service_settings(tmp))) as c:
        reference = None
        for kind, cases in (("tube", m.tube_cases()), ("alignment", m.alignment_cases()),
                            ("perfmap", m.perfmap_cases())):
            for name, filename, data, options, expect in cases:
                outcome, res = submit(c, kind, filename, data, options, 240)
                if kind == "tube":
                    verdict = m.judge_tube_case(expect, outcome, res)
                elif kind == "alignment":
                    if name == "ladder.pcf" and res:
                        reference = {k["id"]: [p["position"] for p in k["ports"]] for k in res["components"]}
                    verdict = m.judge_alignment(expect, outcome, res, reference)
                else:
                    verdict = m.judge_perfmap(expect, outcome, res)
                code, refusal, view = outcome
                said = refusal or ""
                if res is not None:
                    said = ",".join(w["code"] for w in res["report"]["warnings"]) or "ok"
                    if kind == "tube":
                        said += f" r={res['pipe_radius']:.3g}{res['units']} bends={len(res['lra']) - 1}"
                elif view is not None:
                    said = "failed: " + (view.get("summary") or view.get("error") or "")[:160]
                print(json.dumps({"kind": kind, "case": name, "verdict": verdict, "code": code, "said": said}),
                      flush=True)
""")


def main() -> None:
    compare(__doc__.split("\n\n")[0], CHILD, ROOT, BENCH, width=46)


if __name__ == "__main__":
    main()
