"""Tube and alignment cases of the trust58 session, in this tree and a reference checkout side by side (each tree in
a child process of its own, its code first on ``sys.path``): what each answers, in a word or two.

- order: a network written otherwise (renamed, reordered, a PCF's blocks shuffled) whose candidate cuts tie: are
  the same connections cut? (``same`` / ``CUT ELSEWHERE`` and how far the ports moved);
- radius: one component's radius (a PCF item's bores) typed with a wrong exponent or in another unit;
- units: a request file's ``units`` refused in every kind's words;
- inspection: a real tube report's verdict on a failed / undetermined part, and the plot's colour of an end point
  the samples stop short of.

    python bench/trust58_tubealign.py [--ref /work/main]
"""

from __future__ import annotations

import json
from pathlib import Path

import mistakes_table as table  # bench/, the script's folder, is first on sys.path; one BLAS thread

ROOT = Path(__file__).resolve().parent.parent
EXAMPLES = ROOT / "examples"


def _straight_run() -> dict:
    """Two fixed flanges 8 mm apart in height, a pipe between them half as high: both connections measure 4 mm."""
    o = [1.0e6, 2.0e5, 1.0e4]
    port = lambda p, d: {"position": [o[0] + p[0], o[1] + p[1], o[2] + p[2]], "direction": d}
    flange = lambda cid, x0, z: {"id": cid, "kind": "fitting", "type": "flange", "fixed": True, "radius": 50.0,
                                 "ports": [port([x0, 0, z], [-1, 0, 0]), port([x0 + 100, 0, z], [1, 0, 0])]}
    return {"units": "mm", "components": [
        flange("FA", -100, 0.0), {"id": "P", "kind": "pipe", "radius": 50.0,
                                  "ports": [port([0, 0, 4], [-1, 0, 0]), port([6000, 0, 4], [1, 0, 0])]},
        flange("FB", 6000, 8.0)],
        "connections": [{"from": ["FA", 1], "to": ["P", 0]}, {"from": ["P", 1], "to": ["FB", 0]}],
        "options": {"method": "direct"}}


def _tee_pcf(names: dict[str, str]) -> str:
    o = (1.0e6, 2.0e5, 1.0e4)
    pt = lambda kw, p, bore=True: (f"    {kw} " + " ".join(f"{a + b:.4f}" for a, b in zip(o, p))
                                   + (" 100.0000" if bore else ""))
    lines = ["ISOGEN-FILES ISOGEN.FLS", "UNITS-BORE MM", "UNITS-CO-ORDS MM", "PIPELINE-REFERENCE 100-CW-1",
             "TEE", f"    COMPONENT-IDENTIFIER {names['T']}", pt("END-POINT", (150, 0, 0)),
             pt("END-POINT", (-150, 0, 0)), pt("CENTRE-POINT", (0, 0, 0), False), pt("BRANCH1-POINT", (0, -150, 0))]
    for side, s in (("R", 1), ("L", -1)):
        lines += ["PIPE", f"    COMPONENT-IDENTIFIER {names[side + 'P']}", pt("END-POINT", (s * 150, 0, 3)),
                  pt("END-POINT", (s * 4000, 0, 3)),
                  "FLANGE", f"    COMPONENT-IDENTIFIER {names[side + 'F']}", pt("END-POINT", (s * 4000, 0, 6)),
                  pt("END-POINT", (s * 4100, 0, 6))]
    return "\n".join(lines) + "\n"


def _order_cases():
    import copy

    import numpy as np

    from plantsolve.schemas.alignment import AlignmentRequest
    from plantsolve.solvers.alignment.solve import solve
    from plantsolve.solvers.alignment.upload import parse_upload
    from plantsolve.solvers.base import StoredInput

    def answer(request):
        result = solve(request).result
        at = {(c.id, k): tuple(p.position) for c in request.components for k, p in enumerate(c.ports)}
        cuts = {frozenset({at[tuple(c.from_)], at[tuple(c.to)]}) for c in result.connections if c.cut}
        return cuts, {at[(c.id, k)]: np.array(p.position) for c in result.components for k, p in enumerate(c.ports)}

    def said(a, b):
        move = max(float(np.linalg.norm(a[1][k] - b[1][k])) for k in a[1])
        return ("same" if a[0] == b[0] else "CUT ELSEWHERE") + f", ports {move:.2g} mm apart"

    body = _straight_run()
    renamed = copy.deepcopy(body)
    names = {"FA": "z", "P": "y", "FB": "x"}
    for c in renamed["components"]:
        c["id"] = names[c["id"]]
    for c in renamed["connections"]:
        c["from"][0], c["to"][0] = names[c["from"][0]], names[c["to"][0]]
    yield "order: symmetric run (JSON), ids renamed", said(answer(AlignmentRequest.model_validate(body)),
                                                             answer(AlignmentRequest.model_validate(renamed)))
    renamed["components"] = renamed["components"][::-1]
    renamed["connections"] = [{"from": c["to"], "to": c["from"]} for c in renamed["connections"][::-1]]
    yield "order: symmetric run (JSON), renamed and reversed", said(answer(AlignmentRequest.model_validate(body)),
                                                                     answer(AlignmentRequest.model_validate(renamed)))

    def pcf(names):
        text = _tee_pcf(names)
        return answer(parse_upload(StoredInput.from_bytes("tee.pcf", text.encode()),
                                   {"fixed_components": [names["T"], names["RF"], names["LF"]]}))

    same = {k: k for k in ("T", "RP", "RF", "LP", "LF")}
    yield "order: PCF tee with two tied runs, ids renamed", said(pcf(same), pcf(
        {"T": "a", "RP": "b", "RF": "c", "LP": "d", "LF": "e"}))  # the names sort the other way round


def _radius_cases():
    from plantsolve.schemas.alignment import AlignmentRequest
    from plantsolve.solvers.alignment.solve import solve
    from plantsolve.solvers.alignment.upload import parse_upload
    from plantsolve.solvers.alignment.validation import check_input
    from plantsolve.solvers.base import InputRejected, StoredInput

    def outcome(request):
        try:
            check_input(request)
        except InputRejected as refused:
            return "422 " + ".".join(map(str, refused.errors[0].loc))
        result = solve(request).result
        codes = [w.code for w in result.report.warnings]
        return f"{len(result.cut_connections)} cut" + (f", warns {' '.join(codes)}" if codes else ", no word")

    body = json.loads((EXAMPLES / "alignment/ladder.json").read_text())
    for index, radius, what in ((1, 1e6, "an elbow's radius 1e6 mm (pipes 50)"), (6, 5e4, "a pipe's radius 5e4 mm")):
        changed = json.loads(json.dumps(body))
        changed["components"][index]["radius"] = radius
        yield f"radius: JSON, {what}", outcome(AlignmentRequest.model_validate(changed))
    text = (EXAMPLES / "alignment/ladder.pcf").read_text()
    for end in ("202997.80344555186 9995.887503446393", "202848.42626192237 9996.563449806907"):
        text = text.replace(f"{end} 100.0000", f"{end} 1e7", 1)
    try:
        request = parse_upload(StoredInput.from_bytes("ladder.pcf", text.encode()), {"fixed_components": ["N0-0"]})
    except InputRejected as refused:
        yield "radius: PCF, an elbow's bores 1e7 mm", "422 " + ".".join(map(str, refused.errors[0].loc))
    else:
        yield "radius: PCF, an elbow's bores 1e7 mm", outcome(request)


def _units_cases():
    from plantsolve.solvers.base import InputRejected, StoredInput
    from plantsolve.solvers.kinds import load_kinds

    kinds = load_kinds(())
    for kind, path, unit in (("tube", "tube/scan_request.json", "µm"), ("alignment", "alignment/ladder.json", "µm"),
                             ("flowmeter", "flowmeter/meter.json", "yd")):
        body = {**json.loads((EXAMPLES / path).read_text()), "units": unit}
        try:
            kinds[kind].parse_upload(StoredInput.from_bytes("r.json", json.dumps(body).encode()), None)
            said = "accepted"
        except InputRejected as refused:
            said = refused.errors[0].msg.split(";")[0].split(",")[0][:44]
        yield f"units: {kind} file.units {unit!r}", said


def _inspection_cases():
    import numpy as np

    from plantsolve.schemas.tube import TubeRequest
    from plantsolve.solvers.tube.artifacts import inspection_figure
    from plantsolve.solvers.tube.model import build_spine
    from plantsolve.solvers.tube.solve import solve
    from plantsolve.solvers.tube.synthetic import make_model, surface_samples

    rows = [[80.0, 0.0, 90.0, 18.0], [45.0, 90.0, 45.0, 18.0], [30.0, -45.0, 30.0, 18.0], [70.0, 0.0, 0.0, 0.0]]
    model = make_model(rows, 6.0)
    pts = surface_samples(model, 2500, np.random.default_rng(5), noise=0.01)
    spine = build_spine(model)
    short = pts[(pts - spine.start[-1]) @ spine.tangent[-1] < 30.0]
    nominal = [dict(zip(("length", "rotation", "angle", "bend_radius"), r)) for r in rows]
    bent = [dict(n) for n in nominal]
    bent[1]["angle"] = 48.0
    for what, points, nom in (("angle 3 deg off", pts, bent), ("end straight cut short", short, nominal)):
        request = TubeRequest.model_validate({"points": points.tolist(), "options": {"nominal": nom}})
        result = solve(request).result
        verdict = result.report.verdict
        yield f"inspection: {what}", f"{result.inspection.verdict}, report {verdict.label if verdict else 'none'}"
        if what.startswith("end"):
            fig = inspection_figure(request, result)
            colours = [line.get_color() for line in fig.axes[0].get_lines() if line.get_marker() == "D"]
            yield "inspection: plot of an end not determined", {"C0": "blue (pass)", "0.7": "grey"}.get(
                colours[-1], colours[-1])


def main() -> None:
    args = table.arguments(__doc__, cases=False).parse_args()
    if args.child:
        table.case_lines((_order_cases, _radius_cases, _units_cases, _inspection_cases))
        return
    trees = table.trees(args, __file__, key=table.by_case)
    answers = {label: {row["case"]: row["said"] for row in rows} for label, rows in trees}
    width = max(len(row["case"]) for row in trees[-1][1])
    print(f"{'case':{width}s} | " + " | ".join(label for label, _ in trees))
    for row in trees[-1][1]:
        print(f"{row['case']:{width}s} | " + " | ".join(answers[label].get(row["case"], "-") for label, _ in trees))


if __name__ == "__main__":
    main()
