"""Benchmark of the alignment solver: both methods side by side.

Scan-like grid networks (every cell a loop, inline valves, two tie-ins at opposite corners,
plant-scale coordinates around 1e6 mm): pipes perturbed ~2 mm / 0.3 deg, fittings
~6 mm / 1.5 deg. Each run happens in a fresh process so its peak memory can be measured.

    python bench/alignment.py            # 100, 1,000 and 10,000 components
    python bench/alignment.py --quick    # 100 and 1,000 components

Targets: 1,000 components < 2 s, 10,000 < 30 s, memory linear.

Then the scaling tables of the direct method, for two families: the square loop grids above
(about 1,000, 3,500, 10,000 and 35,000 components) and plant-like networks (runs with branches,
a loop per ~500 nodes, a tie-in at every 500th run end: 10,000, 40,000 and 100,000 components;
--quick stops at 10,000 and 10,000). Wall and CPU time, peak memory, the largest gap left, the
exponent k of CPU time ~ components^k (and of memory) fitted between each size and the one before.
Every size runs as ``this`` (the default: the Schur complement's LDL^T where it is positive definite),
as ``lu`` (the same code within ``kkt.use_schur(False)``: every KKT system by the pivoted LU),
and with ``--before DIR`` on the code in DIR (a checkout of another revision, only read, e.g.
main), side by side, each with the largest difference of any port position from ``this``:

    python bench/alignment.py --scaling-only --before /path/to/main/checkout

``--family conflict``: the same grids with the second tie-in placed 30 mm and 2 degrees off, so connections are
cut; every family also runs the request shuffled (``shuf``, ``shufLU``: components and connections in another
order, about half the connections named from their other end), and says whether the same connections were cut
(``same``). ``--side N`` runs only that size (a short run), ``--code`` only the rows named beside ``this``:

    python bench/alignment.py --scaling-only --family conflict --side 12
    python bench/alignment.py --scaling-only --family plant --side 132 --code lu --code before --before DIR

``--repeat N`` runs every size and code N times, interleaved (this, lu, before, this, ...: a loaded machine's
drift falls on all of them), then prints the least CPU time of each and the exponents between them, from the first
size to the last too (#42's goal: plant-like 4,839 -> 19,365 components, ``--side 46 --side 92``); four runs of one
code (2026-11-30, ``this`` and ``before`` both at main, load 12 on 2 cores) gave 0.97, 1.04, 1.10 and 1.21 for it.
``--steps`` prints this code's KKT solves per stage and phase
(rotation; the joint stage's steps with the cost, feasibility steps, and the crawl below what snapping closes): Gauss-
Newton steps, the refinement steps that ``iter`` counts, fresh factorisations, CPU seconds and residuals. It shows
what the iteration count is: the joint stage runs to its cap of 25 Gauss-Newton steps, each 1 to 30 refinement steps
depending on how close the hardest loop is to its singular point, not on the network's size:

    python bench/alignment.py --scaling-only --family plant --side 46 --side 92 --code lu --code before \
        --before DIR --repeat 2 --steps

``--instructions`` counts the instructions of the solve alone (the request is built before) under
``valgrind --tool=callgrind``, which repeats to a few parts in a million where CPU seconds on a loaded machine move
by 20 %: each size and code once (``--side``, default 46 and 92: 4,839 and 19,365 plant-like components; ``--code``
as above), the exponent of instructions ~ components^k between sizes, iterations, the largest port difference from
``this`` and whether the same connections were cut. About 50 times slower than the solve (the 19,365-component
network: ~10 minutes a code). The counts and per-function profiles stay in ``--callgrind-dir`` for
``callgrind_annotate --inclusive=yes``:

    python bench/alignment.py --instructions --family plant --side 46 --side 66 --side 92 --code lu \
        --code before --before DIR
``--conflicts``: the cut choice on 360 small synthetic conflicts (loop grids of 2 x 2 to 4 x 3 nodes, 6 seeds, 6
placements of the second tie-in, with and without inline valves), each solved as written, with its components
renamed (ids sorting the other way), shuffled, in cm and moved rigidly: cuts, answers that move a component more
than 145 mm (a fold: an elbow's arm is 150 mm), how many variants cut other connections than the request as
written, and with ``--before DIR`` the answers closer to or further from the request than that checkout's:

    python bench/alignment.py --conflicts --before DIR
"""

from __future__ import annotations

import argparse
import json
import math
import multiprocessing as mp
import os
import re
import resource
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

SIZES = {100: 6, 1000: 18, 10000: 55}  # target size -> grid side
SCALING_SIDES = (18, 31, 55, 99)  # 1,161 / 3,351 / 10,661 / 34,749 components
PLANT_SIDES = (66, 132, 208)  # plant-like: about 10,000 / 40,000 / 100,000 components
CONFLICT_SIDES = (12, 31)  # loop grids with a misplaced tie-in: about 520 / 3,351 components, cut


def _rss_kib(field: str) -> int:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith(field):
            return int(line.split()[1])
    return 0


def _cpu_s() -> float:
    use = resource.getrusage(resource.RUSAGE_SELF)
    return use.ru_utime + use.ru_stime


def plant_network(side: int, seed: int = 7, options: dict | None = None):
    """A plant-like network on a ``side`` x ``side`` lattice of nodes 3 m apart: a random spanning tree
    (runs that branch at tees and crosses, bends at elbows, caps at the ends), plus one extra edge per
    ~500 nodes (a few loops), an inline valve on every 7th edge, a tie-in at every 500th cap (run end)
    and the first; scan-like noise as in the grids (pipes ~2 mm / 0.3 deg, fittings
    ~6 mm / 1.5 deg), coordinates around 1e6 mm."""
    import numpy as np
    import scipy.sparse as sp
    from scipy.sparse.csgraph import minimum_spanning_tree
    from scipy.spatial.transform import Rotation

    from plantsolve.schemas.alignment import AlignmentRequest

    rng = np.random.default_rng(seed)
    spacing, arm, org = 3000.0, 150.0, np.array([1.0e6, 2.0e5, 1.0e4])
    node = np.arange(side * side).reshape(side, side)
    ea = np.concatenate([node[:-1, :].ravel(), node[:, :-1].ravel()])
    eb = np.concatenate([node[1:, :].ravel(), node[:, 1:].ravel()])
    g = sp.coo_matrix((rng.random(len(ea)) + 1.0, (ea, eb)), shape=(side * side,) * 2)
    tree = minimum_spanning_tree(g).tocoo()
    in_tree = set(zip(tree.row.tolist(), tree.col.tolist())) | set(zip(tree.col.tolist(), tree.row.tolist()))
    spare = [k for k in range(len(ea)) if (ea[k], eb[k]) not in in_tree]
    extra = rng.choice(spare, size=max(1, side * side // 500), replace=False)
    edges = [(int(a), int(b)) for a, b in zip(tree.row, tree.col)] + [(int(ea[k]), int(eb[k])) for k in extra]
    xy = np.stack(np.divmod(np.arange(side * side), side), axis=1).astype(float) * spacing
    nbrs: dict[int, list[int]] = {}
    for a, b in edges:
        nbrs.setdefault(a, []).append(b)
        nbrs.setdefault(b, []).append(a)
    leaves = sorted(k for k, v in nbrs.items() if len(v) == 1)
    tie_ins = set(leaves[::500])
    comps, conns, port_of = [], [], {}

    def add(cid, kind, ftype, ports, noise, fixed=False, up=None):
        centre = np.mean([p for p, _ in ports], axis=0)
        if not fixed:
            rot = Rotation.from_rotvec(rng.normal(size=3) * np.radians(noise[1]) / np.sqrt(3))
            shift = rng.normal(size=3) * noise[0] / np.sqrt(3)
            ports = [(rot.apply(p - centre) + centre + shift, rot.apply(d)) for p, d in ports]
            up = None if up is None else rot.apply(up).tolist()
        comp = {"id": cid, "kind": kind, "radius": 50.0, "fixed": fixed,
                "ports": [{"position": (p + org).tolist(), "direction": np.asarray(d).tolist()} for p, d in ports]}
        if ftype:
            comp["type"] = ftype
        if up is not None:
            comp["up"] = up
        comps.append(comp)

    for k, nb in sorted(nbrs.items()):
        c = np.array([*xy[k], 0.0])
        dirs = [np.array([*(xy[j] - xy[k]) / spacing, 0.0]) for j in nb]
        straight = len(nb) == 2 and float(dirs[0] @ dirs[1]) < -0.5
        ftype = "other" if straight else {1: "cap", 2: "elbow", 3: "tee", 4: "cross"}[len(nb)]
        add(f"N{k}", "fitting", ftype, [(c + arm * d, d) for d in dirs], (6.0, 1.5), fixed=k in tie_ins)
        for i, j in enumerate(nb):
            port_of[(k, j)] = (f"N{k}", i)
    for e, (a, b) in enumerate(edges):
        u = np.array([*(xy[b] - xy[a]) / spacing, 0.0])
        start, end = np.array([*xy[a], 0.0]) + arm * u, np.array([*xy[b], 0.0]) - arm * u
        if (e + 1) % 7 == 0:
            mid = 0.5 * (start + end)
            v0, v1 = mid - 150 * u, mid + 150 * u
            add(f"P{e}a", "pipe", None, [(start, -u), (v0, u)], (2.0, 0.3))
            add(f"V{e}", "fitting", "valve", [(v0, -u), (v1, u)], (6.0, 1.5), up=[0.0, 0.0, 1.0])
            add(f"P{e}b", "pipe", None, [(v1, -u), (end, u)], (2.0, 0.3))
            chain = [(f"P{e}a", 0), (f"P{e}a", 1), (f"V{e}", 0), (f"V{e}", 1), (f"P{e}b", 0), (f"P{e}b", 1)]
        else:
            add(f"P{e}", "pipe", None, [(start, -u), (end, u)], (2.0, 0.3))
            chain = [(f"P{e}", 0), (f"P{e}", 1)]
        ends = [port_of[(a, b)]] + chain + [port_of[(b, a)]]
        conns += [{"from": list(ends[i]), "to": list(ends[i + 1])} for i in range(0, len(ends), 2)]
    return AlignmentRequest.model_validate({"units": "mm", "components": comps, "connections": conns,
                                            "options": options or {}})


def _request(side: int, family: str, options: dict):
    """The network of ``family`` (``grid``, ``plant`` or ``conflict``) and ``side``, with ``options``."""
    from plantsolve.solvers.alignment.synthetic import grid_network

    if family == "plant":
        return plant_network(side, options=options)
    if family == "conflict":
        from plantsolve.solvers.alignment.synthetic import conflicting_tie_ins

        return conflicting_tie_ins(side, side, seed=2024, shift=(0.0, 30.0, 0.0), turn=2.0, valve_every=7,
                                   options=options)
    return grid_network(side, side, valve_every=7, tie_ins=((0, 0), (side - 1, side - 1)),
                        origin=(1.0e6, 2.0e5, 1.0e4), seed=2024, options=options)


def _run(side: int, method: str, max_iterations: int | None, queue, code: str | None = None,
         family: str = "grid", lu: bool = False, shuffled: bool = False, steps: bool = False) -> None:
    if code is not None:
        # the child has imported nothing of plantsolve yet, so this checkout is the one it loads
        sys.path.insert(0, code)
    import contextlib

    from plantsolve.solvers.alignment.solve import solve

    options = {"method": method} if max_iterations is None else {"method": method, "max_iterations": max_iterations}
    req = _request(side, family, options)
    mode = contextlib.nullcontext()
    if lu:
        from plantsolve.solvers.alignment.kkt import use_schur
        mode = use_schur(False)
    given = req
    if shuffled:  # asked of checkouts that have it only (an older baseline has no reordered())
        from plantsolve.solvers.alignment.synthetic import reordered

        given = reordered(req)
    stages = _time_stages()
    solves = _trace_solves() if steps else []
    base = _rss_kib("VmRSS")
    t0, c0 = time.perf_counter(), _cpu_s()
    with mode:
        solved = solve(given)
    res = getattr(solved, "result", solved)  # a --before checkout older than the Solved contract returns the result
    wall, cpu = time.perf_counter() - t0, _cpu_s() - c0
    d = res.report.details
    by_id = {c.id: c for c in res.components}  # in the order of the request as generated, whatever was solved
    cut = {frozenset((tuple(res.connections[k].from_), tuple(res.connections[k].to))) for k in res.cut_connections}
    queue.put({
        "positions": [p.position for c in req.components for p in by_id[c.id].ports],
        "cut_set": sorted(tuple(sorted(x)) for x in cut),
        "components": len(req.components), "connections": len(req.connections), "method": method, "converged": res.converged,
        "iterations": res.iterations, "wall_s": wall, "cpu_s": cpu, "peak_mib": (_rss_kib("VmHWM") - base) / 1024.0,
        "process_mib": _rss_kib("VmHWM") / 1024.0,
        "max_gap": res.max_position_error, "solver_residual": d["snap_distortion"]["position"] if res.converged else res.max_position_error,
        "pipe_axis_mean": d["pipe_axis_movement"]["mean"], "fitting_mean": d["fitting_displacement"]["mean"],
        "cuts": len(res.cut_connections), "stop": d["stop_reason"],
        "rounds": _rounds_said(d.get("rounds") or [], stages),
        "solves": solves,
    })


def _time_stages() -> list[tuple[str, int, float]]:
    """(what, steps, CPU seconds) of every call of the direct method's two stages (rotation averaging, joint
    Gauss-Newton: two per round), of a stalled round's continuation and of a conflict's settling in this child
    process, in order. The functions are wrapped where their callers look them up; a checkout without them leaves the
    list empty."""
    from plantsolve.solvers.alignment import direct, solve

    calls: list[tuple[str, int, float]] = []
    for module, name in ((direct, "solve_rotations"), (direct, "solve_joint"), (solve, "continue_closing"),
                         (solve, "settle_conflict")):
        inner = getattr(module, name, None)
        if inner is None:
            calls.clear()
            return calls

        def timed(*args, _inner=inner, _name=name, **kwargs):
            c0 = _cpu_s()
            out = _inner(*args, **kwargs)
            calls.append((_name, int(out[1]), _cpu_s() - c0))
            return out

        setattr(module, name, timed)
    return calls


def _trace_solves() -> list[dict]:
    """Every KKT solve of the rotation stage, the joint stage and a continuation in this child process, in order:
    the stage, the joint stage's phase (``cost``: steps with the cost's gradient; ``feasibility``: minimum-norm steps
    onto the constraints; ``crawl``: feasibility steps once every connection is within what snapping closes), the
    largest constraint residual the step starts from (relative: lengths in typical component lengths, directions in
    radians), its refinement steps (what ``iterations`` counts) and whether it factored afresh or refined on an
    earlier step's factorisation. ``direct.constrained_lstsq`` is wrapped where the stages look it up; the residual at
    the start costs one product with the constraints per solve (a few dozen per round), which the traced run's CPU time
includes."""
    import sys as _sys

    import numpy as np

    from plantsolve.solvers.alignment import direct

    found: list[dict] = []
    inner = direct.constrained_lstsq

    def traced(H, g, A, residual, **kwargs):
        cache = kwargs.get("cache")
        held = cache.get("lu") if cache is not None else None
        start = float(np.max(np.abs(residual(np.zeros(H.shape[0]))), initial=0.0))
        c0 = _cpu_s()
        out = inner(H, g, A, residual, **kwargs)
        stage = _sys._getframe(1).f_code.co_name
        phase = ("crawl" if cache.get("crawl") else "cost" if np.any(g) else "feasibility") \
            if stage == "solve_joint" else ""
        found.append({"stage": stage, "phase": phase, "start": start, "steps": int(out[2]),
                      "fresh": cache is None or cache.get("lu") is not held, "cpu_s": _cpu_s() - c0})
        return out

    direct.constrained_lstsq = traced
    return found


def _steps_said(solves: list[dict]) -> list[str]:
    """The traced solves (:func:`_trace_solves`) per stage and phase: Gauss-Newton steps, refinement steps, how many
    factored afresh, CPU seconds, the residual at the phase's first and last step, and each step's refinement steps
    (``*``: a fresh factorisation)."""
    lines, groups = [], []
    for s in solves:
        key = (s["stage"], s["phase"])
        if groups and groups[-1][0] == key:
            groups[-1][1].append(s)
        else:
            groups.append((key, [s]))
    for (stage, phase), group in groups:
        name = {"solve_rotations": "rotation", "solve_joint": "joint", "continue_closing": "continued"}.get(stage, stage)
        each = " ".join(f"{s['steps']}{'*' if s['fresh'] else ''}" for s in group)
        lines.append(f"    {name:>9} {phase:>11}: {len(group):>3} GN steps, {sum(s['steps'] for s in group):>4} "
                     f"refinement steps, {sum(s['fresh'] for s in group):>3} fresh, "
                     f"{sum(s['cpu_s'] for s in group):6.2f} s, residual {group[0]['start']:.1e} -> "
                     f"{group[-1]['start']:.1e}  [{each}]")
    return lines


def _rounds_said(rounds: list[dict], stages: list[tuple[str, int, float]]) -> str:
    """Each round's iterations and factorisation, with its stages' steps and CPU seconds where they were timed
    (``rotation steps + joint steps``, ``rotation s + joint s``; a continuation's or a settling's steps and seconds)."""
    kinds = []
    for r in rounds:
        kinds.append(["continue_closing"] if r.get("continuation") else ["settle_conflict"] if r.get("settled")
                     else ["solve_rotations", "solve_joint"])
    timed = [name for name, *_ in stages] == [k for ks in kinds for k in ks]
    said, at = [], 0
    for r, ks in zip(rounds, kinds):
        what = "continued" if r.get("continuation") else "settled" if r.get("settled") else ""
        text = f"{r['iterations']} {r['factorisation']}" + (f" {what}" if what else "") + \
            ("" if r["counted"] else " (not counted)")
        if timed:
            part = stages[at:at + len(ks)]
            at += len(ks)
            text += f" [{'+'.join(str(k) for _, k, _ in part)} steps, {'+'.join(f'{c:.1f}' for *_, c in part)} s]"
        said.append(text)
    return " + ".join(said)


def run_case(side: int, method: str, max_iterations: int | None, code: str | None = None, family: str = "grid",
             lu: bool = False, shuffled: bool = False, steps: bool = False) -> dict:
    ctx = mp.get_context("fork")
    q = ctx.Queue()
    p = ctx.Process(target=_run, args=(side, method, max_iterations, q, code, family, lu, shuffled, steps))
    p.start()
    out = q.get()
    p.join()
    return out


def _exponent(small: dict | None, large: dict, key: str) -> str:
    if small is None or small[key] <= 0 or large[key] <= 0:
        return ""
    return f"{math.log(large[key] / small[key]) / math.log(large['components'] / small['components']):.2f}"


def scaling(quick: bool, before: str | None, family: str = "grid", only: list[int] | None = None,
            codes: list[str] | None = None, repeat: int = 1, steps: bool = False) -> None:
    """Direct method on growing networks of one family: this code, the same code within ``use_schur(False)``,
    the same network shuffled (order and connection ends), and with ``before`` the code in that directory.
    ``repeat``: every size and code that many times, interleaved (this, lu, before, this, lu, before, ...), then the
    least CPU time of each and the exponents between them; ``steps``: this code's KKT solves per stage and phase
    (:func:`_steps_said`)."""
    import numpy as np

    sides = {"grid": SCALING_SIDES[:-1] if quick else SCALING_SIDES, "plant": PLANT_SIDES[:1] if quick else PLANT_SIDES,
             "conflict": CONFLICT_SIDES[:1] if quick else CONFLICT_SIDES}[family]
    sides = only or sides
    runs = [("this", None, False, False), ("lu", None, True, False), ("shuf", None, False, True),
            ("shufLU", None, True, True)] + ([("before", before, False, False)] if before else [])
    runs = [r for r in runs if codes is None or r[0] in codes or r[0] == "this"]
    head = (f"{'code':>6} {'components':>10} {'connections':>11} {'wall s':>8} {'cpu s':>8} {'peak MiB':>9} {'proc MiB':>9} "
            f"{'max gap':>9} "
            f"{'k cpu':>6} {'k mem':>6} {'iter':>5} {'max |dP|':>9} {'cuts':>4} {'same':>4}  stop")
    what = {"grid": "square loop grids", "plant": "plant-like networks",
            "conflict": "square loop grids whose second tie-in is 30 mm and 2 deg off"}[family]
    print(f"\nDirect method, scaling on {what} "
          "(k: exponent of CPU time or memory ~ components^k since the size before; max |dP|: largest difference "
          "of a port position from 'this', in mm; same: the same connections cut as 'this'; shuf: the request "
          "shuffled, half its connections named from the other end)")
    print(head)
    print("-" * len(head))
    rows: dict[str, list[dict]] = {}  # the first pass's, for the ratios
    passes: list[dict[str, list[dict]]] = []
    for rep in range(repeat):
        mine: dict[str, list[dict]] = {}
        passes.append(mine)
        for side in sides:
            here = None
            for label, code, lu, shuffled in runs:
                r = run_case(side, "direct", None, code, family, lu, shuffled, steps and label == "this")
                pos = np.array(r.pop("positions"))
                here = here or {**r, "P": pos}
                dp = float(np.max(np.abs(pos - here["P"]))) if pos.shape == here["P"].shape else float("nan")
                same = "yes" if r.get("cut_set") == here.get("cut_set") else "NO"
                prev = mine.get(label, [None])[-1]
                mine.setdefault(label, []).append(r)
                if rep == 0:
                    rows.setdefault(label, []).append(r)
                print(f"{label:>6} {r['components']:>10} {r['connections']:>11} {r['wall_s']:>8.2f} {r['cpu_s']:>8.2f} "
                      f"{r['peak_mib']:>9.1f} {r['process_mib']:>9.0f} {r['max_gap']:>9.2e} {_exponent(prev, r, 'cpu_s'):>6} {_exponent(prev, r, 'peak_mib'):>6} "
                      f"{r['iterations']:>5} {dp:>9.1e} {r['cuts']:>4} {same:>4}  {r['stop']}"
                      + (f"; rounds: {r['rounds']}" if r["rounds"] else ""), flush=True)
                for line in _steps_said(r["solves"]):
                    print(line, flush=True)
    for label in [x for x, *_ in runs[1:] if x in rows]:
        print(f"\nthis / {label}:")
        for now, old in zip(rows["this"], rows[label]):
            print(f"  {now['components']:>6} components: CPU time {now['cpu_s'] / old['cpu_s']:.2f}, "
                  f"peak memory {now['peak_mib'] / max(old['peak_mib'], 1e-9):.2f}")
    if repeat > 1:
        print(f"\nleast of {repeat} interleaved runs (CPU s, peak MiB, proc MiB; k: exponents between the least; "
              "per pass: each pass's own CPU exponents):")
        for label, *_ in runs:
            least = [{key: min(p[label][i][key] for p in passes) for key in ("cpu_s", "peak_mib", "process_mib")}
                     | {"components": passes[0][label][i]["components"]} for i in range(len(sides))]
            said = []
            for i, r in enumerate(least):
                prev = least[i - 1] if i else None
                per = [_exponent(p[label][i - 1], p[label][i], "cpu_s") for p in passes] if i else []
                said.append(f"{r['components']}: {r['cpu_s']:.2f} s {r['peak_mib']:.0f} / {r['process_mib']:.0f} MiB"
                            + (f" (k cpu {_exponent(prev, r, 'cpu_s')}, k mem {_exponent(prev, r, 'peak_mib')}; "
                               f"per pass {' '.join(per)})" if i else ""))
            if len(least) > 2:
                ends = [_exponent(p[label][0], p[label][-1], "cpu_s") for p in passes]
                said.append(f"first to last k cpu {_exponent(least[0], least[-1], 'cpu_s')}, per pass {' '.join(ends)}")
            print(f"  {label:>6}  " + "; ".join(said))
    print("cpu s: user + system time of the solve (what other load on the machine changes least); peak MiB: "
          "growth of the resident set during the solve (the request is built before); proc MiB: the process's peak "
          "resident set (request and imports included); iter: Gauss-Newton and refinement steps of the rounds "
          "counted (rounds: each round's, with the factorisation it ran on and, in brackets, the steps and CPU seconds "
          "of its rotation averaging + joint Gauss-Newton; LDL^T/LU: the round after a first cut, its feasibility steps on "
          "the LU; continued: a round that ended open, carried on by feasibility steps on the LU; settled: a conflict's "
          "settling, whose pose decides the cut; a round that only its continuation closed is not counted, the LU's "
          "pass of it is).")


# CPython's C functions behind os.getppid() and os.getpgrp(), which the counted child calls just before and just after
# the solve and nothing else calls: callgrind zeroes its counts at the first and writes them out at the second
CALLGRIND_ZERO, CALLGRIND_DUMP = "os_getppid", "os_getpgrp"
# one thread everywhere and a fixed string hash, so that the count is the same from run to run
COUNTED_ENV = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", "PYTHONHASHSEED": "0",
               "PYTHONDONTWRITEBYTECODE": "1"}


def _counted_child(side: int, family: str, code: str | None, lu: bool, out: str) -> None:
    """Run under callgrind by :func:`instructions`: build the request, solve it between the two marker calls, and
    write what the parent compares (iterations, cuts, port positions in the request's order) to ``out``."""
    if code is not None:
        sys.path.insert(0, code)
    import contextlib

    from plantsolve.solvers.alignment.solve import solve

    req = _request(side, family, {"method": "direct"})
    mode = contextlib.nullcontext()
    if lu:
        from plantsolve.solvers.alignment.kkt import use_schur
        mode = use_schur(False)
    os.getppid()
    with mode:
        solved = solve(req)
    os.getpgrp()
    res = getattr(solved, "result", solved)
    by_id = {c.id: c for c in res.components}
    cut = {frozenset((tuple(res.connections[k].from_), tuple(res.connections[k].to))) for k in res.cut_connections}
    Path(out).write_text(json.dumps({
        "components": len(req.components), "connections": len(req.connections), "iterations": res.iterations,
        "cuts": len(res.cut_connections), "cut_set": sorted(tuple(sorted(x)) for x in cut),
        "positions": [p.position for c in req.components for p in by_id[c.id].ports]}))


def _counted(side: int, family: str, label: str, code: str | None, lu: bool, out_dir: Path) -> dict:
    """One solve under ``valgrind --tool=callgrind``: its instruction count and what :func:`_counted_child` wrote."""
    stem = out_dir / f"{family}-{side}-{label}"
    for old in out_dir.glob(stem.name + ".callgrind*"):
        old.unlink()
    cmd = ["valgrind", "--tool=callgrind", f"--callgrind-out-file={stem}.callgrind", "--dump-instr=no",
           f"--zero-before={CALLGRIND_ZERO}", f"--dump-before={CALLGRIND_DUMP}", sys.executable, str(Path(__file__)),
           "--counted-child", str(side), "--family", family, "--child-out", f"{stem}.json"]
    cmd += (["--before", code] if code else []) + (["--child-lu"] if lu else [])
    t0 = time.perf_counter()
    with open(f"{stem}.log", "w") as log:
        subprocess.run(cmd, check=True, stdout=log, stderr=subprocess.STDOUT, env={**os.environ, **COUNTED_ENV})
    dumps = sorted(out_dir.glob(stem.name + ".callgrind.*"))
    if len(dumps) != 1:
        raise RuntimeError(f"{stem}: {len(dumps)} dumps of the solve, expected one (see {stem}.log)")
    found = re.search(r"^totals: (\d+)", dumps[0].read_text(), re.MULTILINE)
    return {**json.loads(Path(f"{stem}.json").read_text()), "instructions": int(found.group(1)),
            "wall_s": time.perf_counter() - t0, "profile": str(dumps[0])}


def instructions(before: str | None, family: str, sides: list[int], codes: list[str] | None, out_dir: Path) -> None:
    """Instruction counts of the direct method's solve under callgrind, this code beside its all-LU path and
    ``before``, and the exponents of instructions ~ components^k between sizes."""
    import numpy as np

    out_dir.mkdir(parents=True, exist_ok=True)
    runs = [("this", None, False), ("lu", None, True)] + ([("before", before, False)] if before else [])
    runs = [r for r in runs if codes is None or r[0] in codes or r[0] == "this"]
    print(f"\nDirect method, instructions of the solve under callgrind ({family}; k: exponent of instructions ~ "
          "components^k since the size before; max |dP|: largest difference of a port position from 'this', mm; "
          "same: the same connections cut as 'this')")
    head = (f"{'code':>6} {'components':>10} {'G instr':>9} {'k instr':>7} {'iter':>5} {'max |dP|':>9} {'cuts':>4} "
            f"{'same':>4} {'wall s':>7}  profile")
    print(head)
    print("-" * len(head))
    rows: dict[str, list[dict]] = {}
    for side in sides:
        here = None
        for label, code, lu in runs:
            r = _counted(side, family, label, code, lu, out_dir)
            pos = np.array(r.pop("positions"))
            here = here or {**r, "P": pos}
            dp = float(np.max(np.abs(pos - here["P"]))) if pos.shape == here["P"].shape else float("nan")
            same = "yes" if r["cut_set"] == here["cut_set"] else "NO"
            prev = rows.get(label, [None])[-1]
            rows.setdefault(label, []).append(r)
            print(f"{label:>6} {r['components']:>10} {r['instructions'] / 1e9:>9.3f} "
                  f"{_exponent(prev, r, 'instructions'):>7} {r['iterations']:>5} {dp:>9.1e} {r['cuts']:>4} {same:>4} "
                  f"{r['wall_s']:>7.0f}  {r['profile']}", flush=True)
    if len(sides) > 2:
        for label, found in rows.items():
            print(f"  {label}: first to last k instr {_exponent(found[0], found[-1], 'instructions')}")
    print("G instr: instructions of the solve alone (callgrind's count from the solve's first call to its return, the "
          "request built before), one thread, PYTHONHASHSEED=0; wall s: the whole child under callgrind.")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="only 100 and 1,000 components; scaling up to 10,000")
    ap.add_argument("--dq-iterations", type=int, default=4000, help="iteration cap of the dual-quaternion method")
    ap.add_argument("--scaling-only", action="store_true", help="only the scaling table of the direct method")
    ap.add_argument("--before", metavar="DIR", help="also run the scaling table on the plantsolve checkout in DIR")
    ap.add_argument("--family", action="append", choices=("grid", "plant", "conflict"),
                    help="only this family's scaling table")
    ap.add_argument("--side", type=int, action="append", help="only networks of this side (a short run)")
    ap.add_argument("--code", action="append", choices=("lu", "shuf", "shufLU", "before"),
                    help="only these rows beside 'this' (a large network once: --code lu --code before)")
    ap.add_argument("--repeat", type=int, default=1,
                    help="every size and code this many times, interleaved; then the least CPU time of each")
    ap.add_argument("--steps", action="store_true",
                    help="this code's KKT solves per stage and phase (Gauss-Newton and refinement steps)")
    ap.add_argument("--conflicts", action="store_true", help="only the cut choice on 360 small synthetic conflicts")
    ap.add_argument("--instructions", action="store_true",
                    help="only instruction counts of the direct method's solve under callgrind (default --side 46 92)")
    ap.add_argument("--callgrind-dir", default="/tmp/alignment-callgrind",
                    help="where --instructions keeps callgrind's profiles")
    ap.add_argument("--counted-child", type=int, metavar="SIDE", help=argparse.SUPPRESS)
    ap.add_argument("--child-lu", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--child-out", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.counted_child is not None:
        _counted_child(args.counted_child, (args.family or ["plant"])[0], args.before, args.child_lu, args.child_out)
        return
    if args.instructions:
        for family in args.family or ("plant",):
            instructions(args.before, family, args.side or [46, 92], args.code, Path(args.callgrind_dir))
        return
    if args.conflicts:
        conflicts(args.before)
        return
    if not args.scaling_only:
        methods(args.quick, args.dq_iterations)
    for family in args.family or ("grid", "plant", "conflict"):
        scaling(args.quick, args.before, family, args.side, args.code, args.repeat, args.steps)


def methods(quick: bool, dq_iterations: int) -> None:
    """Both methods side by side at 100, 1,000 and 10,000 components."""
    sizes = [100, 1000] if quick else [100, 1000, 10000]
    targets = {100: None, 1000: 2.0, 10000: 30.0}
    head = (f"{'components':>10} {'method':>15} {'conv':>5} {'iter':>6} {'wall s':>8} {'target':>7} {'peak MiB':>9} "
            f"{'max gap':>9} {'residual*':>9} {'pipe axis':>9} {'fitting':>8} {'cuts':>4}  stop")
    print(head)
    print("-" * len(head))
    for size in sizes:
        for method in ("direct", "dual_quaternion"):
            r = run_case(SIZES[size], method, dq_iterations)
            tgt = targets[size]
            mark = "" if tgt is None else ("ok" if r["wall_s"] < tgt else "MISS")
            print(f"{r['components']:>10} {method:>15} {r['converged']!s:>5} {r['iterations']:>6} {r['wall_s']:>8.2f} "
                  f"{mark:>7} {r['peak_mib']:>9.1f} {r['max_gap']:>9.2e} {r['solver_residual']:>9.2e} "
                  f"{r['pipe_axis_mean']:>9.3f} {r['fitting_mean']:>8.3f} {r['cuts']:>4}  {r['stop']}", flush=True)
    print("\nmax gap: largest gap left in the result (mm); residual*: solver residual that was snapped to "
          "bit-identical ports (converged runs) or the largest gap (others); pipe axis: mean distance of the "
          "measured pipe ends from the new axis (mm); fitting: mean largest port movement of fittings (mm).")


CONFLICT_GRIDS = ((2, 2), (3, 2), (3, 3), (4, 2), (4, 3))
CONFLICT_SEEDS = range(6)
# where the second tie-in is placed: (shift in mm, turn about z in degrees)
CONFLICT_PLACEMENTS = (((40.0, 0.0, 0.0), 2.0), ((0.0, 0.0, 30.0), 1.0), ((0.0, 30.0, 0.0), 2.0),
                       ((20.0, -20.0, 10.0), 0.5), ((0.0, 0.0, 0.0), 3.0), ((15.0, 0.0, -25.0), 1.5))
CONFLICT_VARIANTS = ("written", "renamed", "shuffled", "cm", "moved")
FOLD_MM = 145.0  # a component moved further than this has been folded over (an elbow's arm is 150 mm)
CLOSER_MM = 20.0  # answers whose largest displacement differs by more than this are closer or further


def conflict_cases() -> list[tuple]:
    """(nx, ny, seed, shift, turn, valve_every) of the 360 conflicts."""
    return [(nx, ny, seed, shift, turn, valves) for nx, ny in CONFLICT_GRIDS for seed in CONFLICT_SEEDS
            for shift, turn in CONFLICT_PLACEMENTS for valves in (0, 3)]


def _variant(body: dict, kind: str):
    """``body`` as the variant ``kind`` states it, with what maps its answer back: (body, names back, mm per unit,
    its rigid motion (R, t) on positions in mm or None)."""
    import numpy as np
    from scipy.spatial.transform import Rotation

    back, mm, motion = {}, 1.0, None
    if kind == "renamed":
        ids = sorted(c["id"] for c in body["components"])
        names = {old: f"z{len(ids) - k:03d}" for k, old in enumerate(ids)}
        back = {new: old for old, new in names.items()}
        body = {**body, "components": [{**c, "id": names[c["id"]]} for c in body["components"]],
                "connections": [{"from": [names[c["from"][0]], c["from"][1]], "to": [names[c["to"][0]], c["to"][1]]}
                                for c in body["connections"]]}
    elif kind == "shuffled":
        from plantsolve.schemas.alignment import AlignmentRequest
        from plantsolve.solvers.alignment.synthetic import reordered

        body = reordered(AlignmentRequest.model_validate(body), seed=5).model_dump(mode="json", by_alias=True)
    elif kind == "cm":
        mm = 10.0
        body = {**body, "units": "cm", "components": [
            {**c, "radius": c["radius"] / 10, "ports": [{**p, "position": [x / 10 for x in p["position"]]}
                                                         for p in c["ports"]]} for c in body["components"]]}
    elif kind == "moved":
        R, t = Rotation.from_rotvec([0.3, -0.2, 0.5]), np.array([125.0, -40.0, 9.0])
        body = {**body, "components": [{**c, "ports": [
            {**p, "position": (R.apply(p["position"]) + t).tolist(), "direction": R.apply(p["direction"]).tolist()}
            for p in c["ports"]]} for c in body["components"]]}
        motion = (R, t)
    return body, back, mm, motion


def _solve_conflicts(code: str | None, queue) -> None:
    """In a child process: every conflict in every variant, by the checkout in ``code`` (None: this one)."""
    if code is not None:
        sys.path.insert(0, code)
    import numpy as np

    from plantsolve.schemas.alignment import AlignmentRequest
    from plantsolve.solvers.alignment.solve import solve
    from plantsolve.solvers.alignment.synthetic import conflicting_tie_ins

    out = []
    c0 = _cpu_s()
    for nx, ny, seed, shift, turn, valves in conflict_cases():
        written = conflicting_tie_ins(nx, ny, seed=seed, shift=shift, turn=turn, valve_every=valves)
        body = written.model_dump(mode="json", by_alias=True)
        case = {}
        for kind in CONFLICT_VARIANTS:
            given, back, mm, motion = _variant(body, kind)
            solved = solve(AlignmentRequest.model_validate(given))
            res = getattr(solved, "result", solved)
            cuts = sorted(tuple(sorted([(back.get(c.from_[0], c.from_[0]), int(c.from_[1])),
                                        (back.get(c.to[0], c.to[0]), int(c.to[1]))]))
                          for c in res.connections if c.cut)
            ports = {}
            for c in res.components:
                for k, p in enumerate(c.ports):
                    x = np.array(p.position) * mm
                    ports[(back.get(c.id, c.id), k)] = x if motion is None else motion[0].inv().apply(x - motion[1])
            case[kind] = {"cuts": cuts, "moved": max(c.displacement for c in res.components) * mm,
                          "converged": res.converged, "ports": ports}
        out.append(case)
    queue.put({"cases": out, "cpu_s": _cpu_s() - c0, "process_mib": _rss_kib("VmHWM") / 1024.0})


def conflicts(before: str | None) -> None:
    """The cut choice on :func:`conflict_cases` (see the module doc), this code and ``before`` in the same run."""
    import numpy as np

    ctx = mp.get_context("fork")
    started = {}
    for label, code in [("this", None)] + ([("before", before)] if before else []):  # side by side: 2 cores
        q = ctx.Queue()
        p = ctx.Process(target=_solve_conflicts, args=(code, q))
        p.start()
        started[label] = (p, q)
    found = {label: q.get() for label, (p, q) in started.items()}
    for p, _ in started.values():
        p.join()
    cases = conflict_cases()
    print(f"\nCut choice on {len(cases)} synthetic conflicts, each in {len(CONFLICT_VARIANTS)} variants "
          f"({', '.join(CONFLICT_VARIANTS)})")
    head = (f"{'code':>6} {'cuts':>5} {'folded':>6} {'unconv':>6} {'variants cut otherwise':>22} "
            f"{'same cuts, max |dP| mm':>22} {'cpu s':>7} {'proc MiB':>8}")
    print(head)
    print("-" * len(head))
    for label, run in found.items():
        rows = run["cases"]
        cuts = sum(len(r["written"]["cuts"]) for r in rows)
        folded = sum(r["written"]["moved"] > FOLD_MM for r in rows)
        unconv = sum(not r[k]["converged"] for r in rows for k in CONFLICT_VARIANTS)
        other = {k: sum(r[k]["cuts"] != r["written"]["cuts"] for r in rows) for k in CONFLICT_VARIANTS[1:]}
        dp = max((max(float(np.linalg.norm(r[k]["ports"][x] - r["written"]["ports"][x])) for x in r[k]["ports"])
                  for r in rows for k in CONFLICT_VARIANTS[1:] if r[k]["cuts"] == r["written"]["cuts"]), default=0.0)
        said = f"{sum(other.values())} (" + " ".join(f"{k} {v}" for k, v in other.items()) + ")"
        print(f"{label:>6} {cuts:>5} {folded:>6} {unconv:>6} {said:>22} {dp:>22.2e} {run['cpu_s']:>7.1f} "
              f"{run['process_mib']:>8.0f}")
    if "before" in found:
        now = np.array([r["written"]["moved"] for r in found["this"]["cases"]])
        old = np.array([r["written"]["moved"] for r in found["before"]["cases"]])
        diff = now - old
        worst = int(np.argmax(diff))
        new_folds = [cases[i] for i in np.flatnonzero((now > FOLD_MM) & (old <= FOLD_MM))]
        same = sum(a["written"]["cuts"] == b["written"]["cuts"] for a, b in zip(found["this"]["cases"],
                                                                                found["before"]["cases"]))
        print(f"\nthis beside before, as written: the same cuts in {same} of {len(cases)}; largest displacement "
              f"closer to the request by more than {CLOSER_MM:g} mm in {int(np.sum(diff < -CLOSER_MM))}, further in "
              f"{int(np.sum(diff > CLOSER_MM))} (the worst by {diff[worst]:.1f} mm: {cases[worst]}); "
              f"newly folded: {new_folds or 'none'}")
    print(f"folded: a component moved more than {FOLD_MM:g} mm; unconv: answers not converged (all variants); "
          "variants cut otherwise: variants whose cuts differ from the request as written; max |dP|: the largest "
          "difference of a port (mm, in the written frame) between a variant and the request as written where both "
          "cut the same connections; cpu s: all solves of the code, in one process.")


if __name__ == "__main__":
    main()
