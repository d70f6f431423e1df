"""How much of an official LDraw set the rigidity solver joins, before and after a change, in one run.

    python bench/rigidity_sets.py FOLDER [FOLDER ...]             # every .ldr / .mpd in the folders
    python bench/rigidity_sets.py FILE.mpd ... --before main      # the baseline: the solver as git ref 'main' has it

Nothing is fetched: the models are read from what is named (the OMR sets of three.js' examples are in
``tests/solvers/rigidity/omr/``). The baseline is the ``plantsolve`` package of ``--before`` (default ``main``;
``--before none`` skips it), taken out of git into a temporary folder and run in a child process on the same
files. Per model, ``before -> after``:

- ``known``: parts read and analysed (in the catalogue; a reader that skips fewer lines reads more), ``unknown``:
  parts not in the catalogue, ``stk``: stickers left out of the analysis and named (the ``stickers`` warning);
- ``floating``: known parts joined to nothing, and their share of the known parts (the target is at most 5 %);
- ``pieces``: connected pieces of the known parts that are no held sub-build (a set that is one build is one
  piece), and ``held``: the pieces the solver recognises as held sub-builds (a minifigure, a droid: whole
  placed sub-models, or minifigure parts only; ``report.details.held_pieces``), and ``apart``: of the pieces not
  held, those the drawing itself places apart (touching no other part, no mate within 10 LDU, no unknown part beside
  them: a second vehicle, accessories laid aside; ``Piece.drawn_apart``, ``report.details.separate_builds``);
- ``offset``: part pairs joined although drawn up to 3 LDU off their mate (the ``offset_joints`` warning);
- ``cont``: part pairs joined by contact only, a part wedged in a gap of another piece (the ``contact_joints``
  warning; a solver before it: 0);
- ``prim``: of the known parts, those the model defines itself, recognised from the official primitives their
  definitions draw (the ``parts_from_primitives`` warning);
- ``verdict``: the report's verdict code after (``one_piece_not_determined``: pieces apart besides held sub-builds and
  pieces drawn apart; ``rigidity_not_determined``: the known parts no majority), ``-`` for none;
- CPU seconds of the parse and solve, and the part numbers of the floating parts after (with counts).

With ``--near`` (no baseline) each model gets a row of its near misses: pairs of connection points of two parts
that would mate (types that fit, directions parallel or opposed within 2.6 degrees; runs and snap cylinders left
out) and are not connected, by how far apart they are drawn (LDU, bands ``0.1-0.25`` … ``2-3``; within 0.1 they
are matched), split into pairs of parts joined otherwise (``j``: a second point of a pair already joined, such as
a bore's second mouth) and pairs of parts not joined to each other (``n``: a joint the tolerance misses, if LDraw's
rounding put it there), with the closest few listed.

With ``--why`` (no baseline) each model not in one piece besides held sub-builds gets a row classing every piece apart
that is no held sub-build by why it is apart: ``B`` drawn apart (a separate build), ``U`` beside a part not in the
catalogue (origins within 60 LDU: it may hold the piece), ``C`` a minifigure with what it holds (at least half of its
parts minifigure parts), ``A8`` a stud and an anti-stud a plate's height (8 LDU) apart on one axis (air or a tile
between), ``A3-10`` another mate 3 to 10 LDU off (its types counted in the totals), ``AT`` the rest: lying against
the build with no mate within 10 LDU (tilted, on a smooth face) or standing off it up to a slip.

Then the totals, after and (with a baseline) before: floating parts, models at most 5 % floating, models in one
piece besides held sub-builds, and besides held sub-builds and pieces drawn apart (each other piece is one whose joint
was not found), pieces not held, held, drawn apart, offset pairs, the verdicts by code, CPU seconds.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tarfile
import tempfile
import time
from collections import Counter
from io import BytesIO
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def measure(path: Path) -> dict:
    from plantsolve.solvers.base import StoredInput
    from plantsolve.solvers.rigidity.solve import solve
    from plantsolve.solvers.rigidity.upload import parse_upload

    start = time.process_time()
    request = parse_upload(StoredInput.from_bytes(path.name, path.read_bytes()), None)
    result = solve(request).result
    seconds = time.process_time() - start
    analysed = {p.id for p in result.parts}  # the known parts (no stickers, no copies beyond a repeat)
    known = [p for p in request.parts if p.id in analysed]
    joined = {b for j in result.joints for b in j.bodies}
    floating = [p for p in known if p.id not in joined]
    details = result.report.details
    held = len(details.get("held_pieces") or [])
    apart = sum(bool(getattr(pc, "drawn_apart", False)) for pc in result.pieces)  # a solver before the field: none
    offsets = next((len(w.details["pairs"]) for w in result.report.warnings if w.code == "offset_joints"), 0)
    recognised = next((len(w.details["ids"]) for w in result.report.warnings if w.code == "parts_from_primitives"), 0)
    stickers = next((w.details["count"] for w in result.report.warnings if w.code == "stickers"), 0)
    contacts = next((len(w.details["pairs"]) for w in result.report.warnings if w.code == "contact_joints"), 0)
    return {"model": path.name, "known": len(known), "unknown": len(result.unknown_parts), "stickers": stickers,
            "floating": len(floating),
            "pieces": details.get("connected_pieces") - held, "held": held, "apart": apart, "offset": offsets,
            "contact": contacts, "dof": result.dof,
            "prim": recognised, "seconds": seconds,
            "verdict": result.report.verdict.code if result.report.verdict else None,
            "floating_parts": dict(Counter(p.part for p in floating))}


WHY = ("B", "U", "C", "A8", "A3-10", "AT")
NEAR_BANDS = (0.25, 0.5, 1.0, 2.0, 3.0)  # LDU: upper ends of the near-miss bands (the lower end of the first: 0.1)


def near_misses(path: Path) -> tuple[Counter, list[tuple]]:
    """(counts by (band, 'j' or 'n'), the closest pairs) of the point pairs of two parts of one model that would mate
    and are drawn 0.1 to 3 LDU apart unconnected (module docstring, ``--near``)."""
    import numpy as np
    from scipy.spatial import cKDTree

    from plantsolve.solvers.base import StoredInput
    from plantsolve.solvers.rigidity.assembly import ALIGN, SNAP
    from plantsolve.solvers.rigidity.catalogue import ANY_DIRECTION, FITS, OPPOSED, mate
    from plantsolve.solvers.rigidity.solve import build, recorded_parts, repeated_placements, set_aside
    from plantsolve.solvers.rigidity.upload import parse_upload

    request = parse_upload(StoredInput.from_bytes(path.name, path.read_bytes()), None)
    stickers, copies = set_aside(request, repeated_placements(request))
    assembly, _ = build(request, recorded_parts(request.source or {})[0], {p.id for p in stickers} | set(copies))
    rows = [(pid, k, c.type, placed.points[k], placed.directions[k]) for pid, placed in assembly.parts.items()
            for k, c in enumerate(placed.shape.connectors) if c.type not in FITS and c.length <= 0]
    used, joined = set(), set()
    for conns in assembly._links.values():  # a bench may look inside: which points each connection took
        for c in conns:
            used.update({(c.a, c.ca), (c.b, c.cb)})
            joined.add(frozenset((c.a, c.b)))
    counts, closest = Counter(), []
    if not rows:
        return counts, closest
    points = np.array([r[3] for r in rows])
    for i, j in cKDTree(points).query_pairs(NEAR_BANDS[-1]):
        (a, ka, ta, pa, da), (b, kb, tb, pb, db) = rows[i], rows[j]
        kind = mate(ta, tb)
        if a == b or kind in (None, "ring") or ((a, ka) in used and (b, kb) in used):
            continue
        cos = float(da @ db)
        if (kind in OPPOSED and cos > -ALIGN) or (kind not in OPPOSED and kind not in ANY_DIRECTION
                                                  and abs(cos) < ALIGN):
            continue
        gap = float(np.linalg.norm(pa - pb))
        if gap <= SNAP:
            continue
        band = next(b for b in NEAR_BANDS if gap <= b)
        side = "j" if frozenset((a, b)) in joined else "n"
        counts[(band, side)] += 1
        closest.append((round(gap, 3), side, f"{assembly.parts[a].number} {ta}", f"{assembly.parts[b].number} {tb}"))
    return counts, sorted(closest)[:3]


def why(path: Path) -> tuple[dict, Counter, Counter]:
    """(the measured row, the pieces apart that are no held sub-build by class (WHY, module docstring), the mate types
    of the A3-10 ones) of one model."""
    from plantsolve.solvers.base import StoredInput
    from plantsolve.solvers.rigidity.misses import Misses, unknown_near
    from plantsolve.solvers.rigidity.pieces import MINIFIG, NAME_MARKS
    from plantsolve.solvers.rigidity.solve import (
        build,
        recorded_parts,
        set_aside,
        solve,
    )
    from plantsolve.solvers.rigidity.solve import repeated_placements as repeats
    from plantsolve.solvers.rigidity.upload import parse_upload

    request = parse_upload(StoredInput.from_bytes(path.name, path.read_bytes()), None)
    result = solve(request).result
    stickers, copies = set_aside(request, repeats(request))
    assembly, unknown = build(request, recorded_parts(request.source or {})[0], {p.id for p in stickers} | set(copies))
    misses = Misses(assembly)
    positions = {p.id: p.position for p in request.parts}
    classes, types = Counter(), Counter()
    for pc in result.pieces[1:]:
        if pc.sub_build is not None:
            continue
        near = misses.nearest(pc.parts)
        gap = near["gap_ldu"] if near else None
        figures = sum(assembly.parts[p].shape.name.lstrip(NAME_MARKS).lower().startswith(MINIFIG) for p in pc.parts)
        if pc.drawn_apart:
            classes["B"] += 1
        elif unknown_near(pc.parts, positions, [u.id for u in unknown]):
            classes["U"] += 1
        elif len(pc.parts) > 1 and 2 * figures >= len(pc.parts):
            classes["C"] += 1
        elif gap is not None and abs(gap - 8) < 0.35 and {near["type"], near["other_type"]} == {"stud", "antistud"}:
            classes["A8"] += 1
        elif gap is not None and gap <= 10:
            classes["A3-10"] += 1
            types["/".join(sorted((near["type"], near["other_type"])))] += 1
        else:
            classes["AT"] += 1
    held = len(result.report.details.get("held_pieces") or [])
    return {"model": path.name, "known": len(result.parts), "pieces": len(result.pieces) - held, "held": held}, \
        classes, types


def baseline(ref: str, files: list[Path]) -> dict[str, dict]:
    """The rows of ``files`` measured with the ``plantsolve`` package of git ``ref``, in a child process."""
    archive = subprocess.run(["git", "archive", "--format=tar", ref, "plantsolve"], cwd=ROOT, check=True,
                             capture_output=True).stdout
    with tempfile.TemporaryDirectory() as folder:
        with tarfile.open(fileobj=BytesIO(archive)) as tar:
            tar.extractall(folder, filter="data")
        # the editable install's import hook would find this checkout's package first: drop it for the child
        boot = ("import runpy, sys; sys.meta_path[:] = [f for f in sys.meta_path if '__editable__' not in "
                f"repr(f)]; sys.path.insert(0, {folder!r}); sys.argv = sys.argv[1:]; "
                "runpy.run_path(sys.argv[0], run_name='__main__')")
        out = subprocess.run([sys.executable, "-c", boot, __file__, "--json", "--before", "none",
                              *map(str, files)], check=True, capture_output=True, text=True).stdout
    return {row["model"]: row for row in map(json.loads, out.splitlines())}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("paths", nargs="+", type=Path, help="folders of .ldr/.mpd models, or model files")
    parser.add_argument("--before", default="main", help="git ref of the baseline solver, or 'none'")
    parser.add_argument("--json", action="store_true", help="one JSON row per model (the baseline's child uses it)")
    parser.add_argument("--why", action="store_true", help="class the pieces apart of each model (no baseline)")
    parser.add_argument("--near", action="store_true", help="near misses of connection points (no baseline)")
    args = parser.parse_args(argv)
    files = []
    for path in args.paths:
        files.extend(sorted(p for p in path.iterdir() if p.suffix.lower() in (".ldr", ".mpd")) if path.is_dir()
                     else [path])
    if args.json:
        for path in files:
            print(json.dumps(measure(path)), flush=True)
        return 0
    if args.near:
        bands = [f"{lo:g}-{hi:g}" for lo, hi in zip((0.1,) + NEAR_BANDS[:-1], NEAR_BANDS)]
        print("| model | " + " | ".join(f"{b} j/n" for b in bands) + " | closest |")
        total = Counter()
        for path in files:
            counts, closest = near_misses(path)
            total.update(counts)
            print(f"| {path.stem} | " + " | ".join(f"{counts[(hi, 'j')]}/{counts[(hi, 'n')]}" for hi in NEAR_BANDS)
                  + " | " + "; ".join(f"{g} {s} {a} - {b}" for g, s, a, b in closest) + " |", flush=True)
        print("all: " + ", ".join(f"{b} LDU {total[(hi, 'j')]} joined otherwise / {total[(hi, 'n')]} not"
                                  for b, hi in zip(bands, NEAR_BANDS)))
        return 0
    if args.why:
        print("| model | known | pieces (not held) | held | " + " | ".join(WHY) + " |")
        all_classes, all_types, split = Counter(), Counter(), 0
        for path in files:
            row, classes, types = why(path)
            all_classes.update(classes)
            all_types.update(types)
            if row["pieces"] > 1:
                split += 1
                print(f"| {path.stem} | {row['known']} | {row['pieces']} | {row['held']} | "
                      + " | ".join(str(classes[k] or "") for k in WHY) + " |", flush=True)
        print(f"{split} of {len(files)} models not in one piece besides held sub-builds; pieces apart by class: "
              + ", ".join(f"{k} {all_classes[k]}" for k in WHY) + "; A3-10 mates: "
              + ", ".join(f"{k} {n}" for k, n in all_types.most_common()))
        return 0
    before = baseline(args.before, files) if args.before != "none" else {}
    print(f"baseline: {args.before}" + (" (plantsolve of that git ref)" if before else ""))
    print(f"{'model':34s} {'known':>9s} {'unknown':>9s} {'stk':>5s} {'floating':>17s} {'pieces':>7s} {'held':>6s} {'apart':>6s} {'offset':>6s} "
          f"{'cont':>5s} {'dof':>9s} {'prim':>6s} {'cpu s':>11s} {'verdict':>24s}  floating parts (after)")
    rows = []
    for path in files:
        row = measure(path)
        rows.append(row)
        old = before.get(row["model"], row if not before else None)

        def pair(key, fmt="d", row=row, old=old):
            return f"{old[key]:{fmt}}>{row[key]:{fmt}}" if old is not None else f"?>{row[key]:{fmt}}"

        share = 100.0 * row["floating"] / row["known"] if row["known"] else 0.0
        names = ", ".join(f"{n} x{c}" if c > 1 else n for n, c in sorted(row["floating_parts"].items()))
        print(f"{row['model'][:34]:34s} {pair('known'):>9s} {pair('unknown'):>9s} {pair('stickers'):>5s} "
              f"{pair('floating'):>8s} ({share:4.1f} %) "
              f"{pair('pieces'):>7s} {pair('held'):>6s} {pair('apart'):>6s} {pair('offset'):>6s} "
              f"{pair('contact'):>5s} {pair('dof'):>9s} {pair('prim'):>6s} "
              f"{pair('seconds', '.2f'):>11s} {row['verdict'] or '-':>24s}  {names}")
    olds = [before.get(row["model"]) for row in rows]
    print(totals("after", rows))
    if all(olds) and olds:
        print(totals(f"before ({args.before})", olds))
    return 0


def totals(label: str, rows: list[dict]) -> str:
    """One line of totals over the models: floating parts, models at most 5 % floating, models in one piece besides
    held sub-builds (the goal: a set that is one build comes out as one piece) and besides held sub-builds and pieces
    drawn apart (a set of several builds said so), pieces not held, held, drawn apart, offset pairs, the verdicts by
    code, CPU seconds."""
    return (f"{label}: {len(rows)} models, {sum(r['known'] for r in rows)} known parts, unknown "
            f"{sum(r['unknown'] for r in rows)}, stickers {sum(r['stickers'] for r in rows)}, floating "
            f"{sum(r['floating'] for r in rows)}, at most 5 % floating "
            f"{sum(r['floating'] <= 0.05 * r['known'] for r in rows)}, one piece "
            f"{sum(r['pieces'] == 1 for r in rows)} (or drawn apart "
            f"{sum(r['pieces'] - r['apart'] == 1 for r in rows)}), "
            f"pieces not held {sum(r['pieces'] for r in rows)}, held {sum(r['held'] for r in rows)}, drawn apart "
            f"{sum(r['apart'] for r in rows)}, offset pairs "
            f"{sum(r['offset'] for r in rows)}, contact pairs {sum(r.get('contact', 0) for r in rows)}, verdicts "
            f"{dict(Counter(r.get('verdict') for r in rows if r.get('verdict'))) or 'none'}, "
            f"CPU {sum(r['seconds'] for r in rows):.1f} s")


if __name__ == "__main__":
    sys.exit(main())
