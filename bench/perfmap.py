"""Benchmark of the perfmap solver.

    python bench/perfmap.py            # full run
    python bench/perfmap.py --quick    # smaller ground truth, one repetition

Prints: solve time for 28 settings x 6 points with a 64 x 64 map (target < 1 s), the map's
efficiency error against a dense ground truth of a synthetic family for the exact method and
for the paper's binning (N = 64, M = 128), the 200 x 200 map time, and the paper's Table 1
for the real N3 fan map; then, per map, the pressure error against the floor (the best any
decreasing concave curve reaches) with the families chosen and the time; then, for every compressor
map shipped with pyCycle, the worst speed line of 'auto' against its floor, before (least-squares fits
only, the previous rule) and after (minimax where no least-squares fit reaches the floor).

    python bench/perfmap.py --pycycle  # the pyCycle table only (and the exports)
    python bench/perfmap.py --export   # the beta grid and cycle-code exports only: time, round-trip error
    python bench/perfmap.py --gasturb  # GSPy's GasTurb/GSP maps: settings found, excess over the floor, round trip
                                       # of the .map export with evenly spaced beta (before) and adaptive (after)
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from plantsolve.schemas.perfmap import PerfmapQueryRequest, PerfmapRequest  # noqa: E402
from plantsolve.solvers.base import StoredInput  # noqa: E402
from plantsolve.solvers.perfmap.query import query  # noqa: E402
from plantsolve.solvers.perfmap.solve import solve  # noqa: E402
from plantsolve.solvers.perfmap.upload import parse_upload  # noqa: E402
from plantsolve.solvers.perfmap.performance_map import binned_map, curve_ranges  # noqa: E402
from plantsolve.solvers.perfmap.families import curveset_from_fits  # noqa: E402
from plantsolve.solvers.perfmap.synthetic import request_body, speed_lines, true_map  # noqa: E402

N3 = Path(__file__).resolve().parents[1] / "examples" / "perfmap" / "n3_fan_map.csv"


def timed(fn, reps):
    times, out = [], None
    for _ in range(reps):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), out


def stage_times(req):
    marks = []
    t0 = time.perf_counter()
    solve(req, lambda f, m="": marks.append((time.perf_counter() - t0, m)))
    first = {}
    for t, m in marks:
        first.setdefault(m.split(":")[0].split(" ")[0], t)
    return first, marks[-1][0]


def errors(est, truth):
    both = np.isfinite(est) & np.isfinite(truth)
    d = (est - truth)[both]
    return {
        "max_abs": float(np.max(np.abs(d))),
        "mean_abs": float(np.mean(np.abs(d))),
        "bias": float(np.mean(d)),
        "missed": int(np.sum(np.isfinite(truth) & ~np.isfinite(est))),
        "false": int(np.sum(~np.isfinite(truth) & np.isfinite(est))),
    }


def main(args) -> None:
    reps = 1 if args.quick else 3
    n_truth = 20001 if args.quick else 200001

    rows = []
    req = PerfmapRequest.model_validate(request_body(n_theta=4, n_phi=7, n_points=6,
                                                     options={"grid": [64, 64]}))
    solve(req)  # warm-up (imports, caches)
    t64, res = timed(lambda: solve(req).result, reps)
    stages, _ = stage_times(req)
    fit_t = stages.get("envelopes", 0.0)
    rows.append(("solve 28 settings x 6 pts, 64x64 map (all 5 families + LOO + map)",
                 f"{t64:.3f} s", "< 1 s", "met" if t64 < 1 else "MISSED"))
    rows.append(("  of which characteristics, Table 1, LOO, envelopes", f"{fit_t:.3f} s", "", ""))
    rows.append(("  of which exact map", f"{t64 - fit_t:.3f} s", "", ""))

    gx, gy = np.array(res.map.flow), np.array(res.map.pressure)
    t0 = time.perf_counter()
    te, tth, tph = true_map(gx, gy, n_t=n_truth)
    t_truth = time.perf_counter() - t0
    eta = np.array(res.map.efficiency, dtype=float)
    ex = errors(eta, te)
    curves = curveset_from_fits(res.settings)
    th = np.array([s.theta for s in res.settings])
    ph = np.array([s.phi for s in res.settings])
    tb, (be, (bth, bph)) = timed(lambda: binned_map(curves, np.array(res.triangles), np.column_stack([th, ph]),
                                                    gx, gy, curve_ranges(curves), 64, 128), reps)
    eb = errors(be, te)
    ok = np.isfinite(te)
    th_ex = float(np.nanmean(np.abs(np.array(res.map.theta, dtype=float) - tth)[ok]))
    th_b = float(np.nanmean(np.abs(bth - tth)[ok & np.isfinite(bth)]))

    t200req = PerfmapRequest.model_validate(request_body(n_theta=4, n_phi=7, n_points=6,
                                                         options={"grid": [200, 200]}))
    t200, _ = timed(lambda: solve(t200req).result, reps)

    n3 = parse_upload(StoredInput.from_bytes("n3_fan_map.csv", N3.read_bytes()), None)
    tn3, n3res = timed(lambda: solve(n3).result, reps)

    # inverse query in bulk (the HTTP handler answers it synchronously): 10,000 duty points
    # over the N3 map's box and 20 % around it (about 3/4 infeasible: distance computed)
    rng = np.random.default_rng(0)
    (x0, x1), (y0, y1) = n3res.flow_range, n3res.pressure_range
    qpts = PerfmapQueryRequest(points=[
        {"flow": a, "pressure": b}
        for a, b in zip(rng.uniform(x0 - 0.2 * (x1 - x0), x1 + 0.2 * (x1 - x0), 10_000),
                        rng.uniform(y0 - 0.2 * (y1 - y0), y1 + 0.2 * (y1 - y0), 10_000))])
    tq, qres = timed(lambda: query(n3res, qpts), reps)
    n_feasible = sum(a.feasible for a in qres.points)

    print(f"\nperfmap benchmark ({'quick' if args.quick else 'full'}; median of {reps}; "
          f"ground truth: dense t search, {n_truth} samples, {t_truth:.1f} s)\n")
    print(f"{'measurement':70s} {'value':>12s}  {'target':>8s}  status")
    for r in rows:
        print(f"{r[0]:70s} {r[1]:>12s}  {r[2]:>8s}  {r[3]}")
    print(f"{'solve 28 settings, 200x200 map':70s} {t200:>10.3f} s  {'':>8s}")
    print(f"{'solve real N3 fan map (18 settings x 7-8 pts, 64x64, auto)':70s} {tn3:>10.3f} s")
    print(f"{'binning baseline map alone (N=64, M=128)':70s} {tb:>10.3f} s")
    print(f"{f'inverse query, 10,000 points on N3 ({n_feasible} feasible)':70s} {tq:>10.3f} s")

    print("\nmap efficiency error vs dense ground truth (synthetic family, 64x64, "
          f"{int(ok.sum())} reachable nodes)")
    print(f"{'method':28s} {'max |err|':>10s} {'mean |err|':>11s} {'bias':>10s} "
          f"{'missed':>7s} {'false':>6s} {'mean |dtheta|':>13s}")
    for name, e, dth in (("exact (M=129 + refinement)", ex, th_ex),
                         ("paper binning N=64, M=128", eb, th_b)):
        print(f"{name:28s} {e['max_abs']:10.2e} {e['mean_abs']:11.2e} {e['bias']:+10.2e} "
              f"{e['missed']:7d} {e['false']:6d} {dth:13.4f}")

    print(f"\nTable 1 for the N3 fan map (max over 18 settings; auto chose '{n3res.family}')")
    print(f"{'family':10s} {'#coef':>5s} {'y':>7s} {'eta':>7s} {'LOO y':>7s} {'LOO eta':>8s} "
          f"{'floor':>7s}")
    pct = lambda v: "   —  " if v is None else f"{100 * v:6.2f}%"  # noqa: E731
    for r in n3res.error_table:
        print(f"{r.family:10s} {r.n_coefficients:5d} {pct(r.pressure_max_rel_error)} "
              f"{pct(r.efficiency_max_rel_error)} {pct(r.pressure_loo)} "
              f" {pct(r.efficiency_loo)} {pct(r.floor)}")
    n_floor = sum(1 for w in n3res.report.warnings if w.code == "data_not_decreasing_concave")
    print(f"settings whose pressures are not decreasing-concave (floor > 0): {n_floor} of "
          f"{len(n3res.settings)}")

    print("\nEfficiency families on the N3 fan map (bounded fits 0 <= eta <= 1; max over "
          "settings; overshoot = fitted peak - measured max of the setting)")
    print(f"{'family':13s} {'#coef':>5s} {'rel':>7s} {'abs':>7s} {'LOO rel':>8s} {'LOO abs':>8s} "
          f"{'overshoot':>9s} {'chosen':>6s}")
    for r in n3res.efficiency_error_table:
        print(f"{r.family:13s} {r.n_coefficients:5d} {pct(r.max_rel_error)} {pct(r.max_abs_error)} "
              f"{pct(r.loo_rel)}  {pct(r.loo_abs)} {r.max_overshoot:+9.4f} {r.chosen:6d}")
    measured = max(max(p.efficiency) for p in n3.positions)
    for label, opts in (("auto (default)", {}),
                        ("paper pairing, spline2", {"model": "spline2", "efficiency_model": "same"})):
        r = n3res if not opts else solve(n3.model_copy(update={
            "options": n3.options.model_copy(update=opts)})).result
        m = np.nanmax(np.array(r.map.efficiency, dtype=float))
        worst = max(r.settings, key=lambda s: s.efficiency_max_rel_error)
        n_poor = sum(w.code == "efficiency_fit_poor" for w in r.report.warnings)
        print(f"N3 map, efficiency {label:24s}: max map eta {m:.4f} (measured max {measured:.4f});"
              f" worst setting ({worst.theta:g}, {worst.phi:g}) {worst.efficiency_family} "
              f"rel {100 * worst.efficiency_max_rel_error:.2f}% abs "
              f"{worst.efficiency_max_abs_error:.4f}; efficiency_fit_poor warnings: {n_poor}")


def pressure_reach() -> None:
    """Per map: how close the pressure characteristics come to the best decreasing concave curve."""
    maps = [
        ("N3 fan (real, 18 settings)", parse_upload(StoredInput.from_bytes("n3_fan_map.csv", N3.read_bytes()), None)),
        ("synthetic family 4x7, cubic data", PerfmapRequest.model_validate(request_body(options={"model": "auto"}))),
        ("speed lines 24x12, choke cliff", PerfmapRequest.model_validate(speed_lines(24, 12, options={"map": False}))),
        ("speed lines 28x20, steep cliff", PerfmapRequest.model_validate(speed_lines(28, 20, steep=16.0,
                                                                                    options={"map": False}))),
        ("speed lines 20x25, cliff + 0.3 % noise", PerfmapRequest.model_validate(
            speed_lines(20, 25, noise=0.003, seed=2, options={"map": False}))),
        ("pyCycle-style map file, 2 alpha x 9 Nc, 64x64 map", parse_upload(
            StoredInput.from_bytes("fan.py", (Path(__file__).resolve().parents[1] / "tests" / "solvers" / "perfmap" / "data" / "pycycle_fan_map.py")
            .read_bytes()), None)),
        ("speed lines 28x12, speed map 96x96", PerfmapRequest.model_validate(
            speed_lines(28, 12, options={"grid": [96, 96]}))),
        ("synthetic 4x7 (theta, phi) with a 96x96 map", PerfmapRequest.model_validate(
            request_body(n_points=12, noise=0.002, seed=1, options={"model": "auto", "grid": [96, 96]}))),
    ]
    print("\nPressure characteristics against the floor (max over lines; excess = error - floor; target <= 1 %)")
    print("| map | lines | pressure max err | floor max | excess max | lines > 1 % | families | eta max abs | "
          "eta max rel | time s |")
    print("|---|---:|---:|---:|---:|---:|---|---:|---:|---:|")
    for name, req in maps:
        t0 = time.perf_counter()
        res = solve(req).result
        dt = time.perf_counter() - t0
        s = res.settings
        fams = {}
        for x in s:
            fams[x.family] = fams.get(x.family, 0) + 1
        print(f"| {name} | {len(s)} | {max(x.pressure_max_rel_error for x in s):.2%} | {max(x.floor for x in s):.2%} "
              f"| {max(x.pressure_excess for x in s):.2%} | {sum(x.pressure_excess > 0.01 for x in s)} "
              f"| {', '.join(f'{k} {v}' for k, v in sorted(fams.items()))} "
              f"| {max(x.efficiency_max_abs_error for x in s):.4f} | {max(x.efficiency_max_rel_error for x in s):.2%} "
              f"| {dt:.2f} |")


def pycycle_floor() -> None:
    """Per pyCycle map: the speed line 'auto' leaves furthest above its floor, before and after.

    Both rules run in this process. 'before': a choke segment only at exactly the largest flow
    (``choke_tolerance=0``), and least-squares fits only (``minimax_fallback=False``); 'after': :func:`prepare` and
    :func:`choose_families` as the solver runs them. CPU seconds (``time.process_time``) are those of the
    choice alone; 'solve' is the whole solve without a map."""
    from plantsolve.solvers.base import no_progress
    from plantsolve.solvers.perfmap.solve import PRESSURE_EXCESS, choose_families, fit_characteristics
    from plantsolve.solvers.perfmap.units import to_internal
    from plantsolve.solvers.perfmap.validation import prepare

    def worst(choice, ch, settings):
        ex = [r.err - f for r, f in zip(choice, ch.floors)]
        k = int(np.argmax(ex))
        f = ch.floors[k]
        ratio = f"{choice[k].err / f:6.2f}" if f > 0 else "   inf"
        return (f"{', '.join(f'{v:g}' for v in settings[k].values):>10s} {100 * f:6.2f}% "
                f"{100 * choice[k].err:6.2f}% {ratio} {100 * ex[k]:+6.2f}%"), sum(e > PRESSURE_EXCESS for e in ex)

    data = Path(__file__).resolve().parents[1] / "tests" / "solvers" / "perfmap" / "data" / "pycycle"
    print("\npyCycle compressor maps (tests/solvers/perfmap/data/pycycle): worst line of 'auto' against its floor "
          "(ratio = auto / floor; excess = auto - floor, target <= 1 %); CPU s of the family choice")
    cols = f"{'worst line':>10s} {'floor':>7s} {'auto':>7s} {'ratio':>6s} {'excess':>7s} {'>1%':>3s} {'cpu s':>6s}"
    before, after = "before (choke at equal flows; least squares)", "after (choke within rounding; minimax where needed)"
    print(f"{'':20s} | {before:^{len(cols)}s} | {after:^{len(cols) + 8}s} |")
    print(f"{'map':14s} {'lines':>5s} | {cols} | {cols} {'minimax':>7s} | {'solve s':>7s}")
    for path in sorted(data.glob("*.py")):
        req = parse_upload(StoredInput.from_bytes(path.name, path.read_bytes()), {"map": False})
        opts = req.options
        old_settings = prepare(to_internal(req)[0], choke_tolerance=0.0)
        old_ch = fit_characteristics(old_settings, False, opts.concave_efficiency, no_progress)
        settings = prepare(to_internal(req)[0])
        ch = fit_characteristics(settings, False, opts.concave_efficiency, no_progress)
        c0 = time.process_time()
        _, before, _, _ = choose_families(old_ch, old_settings, opts, [], minimax_fallback=False)
        c1 = time.process_time()
        _, after, _, _ = choose_families(ch, settings, opts, [])
        c2 = time.process_time()
        solve(req)
        c3 = time.process_time()
        (wb, nb), (wa, na) = worst(before, old_ch, old_settings), worst(after, ch, settings)
        print(f"{path.stem:14s} {len(settings):5d} | {wb} {nb:3d} {c1 - c0:6.3f} | {wa} {na:3d} {c2 - c1:6.3f} "
              f"{sum(r.minimax for r in after):7d} | {c3 - c2:7.2f}")


def agree(res, again):
    """Two fits of the same lines at the same curve parameter: max relative pressure difference (whole line, first
    90 %), max absolute efficiency difference."""
    c1, c2 = curveset_from_fits(res.settings), curveset_from_fits(again.settings)
    by = {tuple(x.setting): k for k, x in enumerate(res.settings)}
    t = np.linspace(0, 1, 401)
    pa = pb = ea = 0.0
    for k2, x in enumerate(again.settings):
        k = by[tuple(x.setting)]
        _, y1, e1 = c1.evaluate(np.full(401, k), t)
        _, y2, e2 = c2.evaluate(np.full(401, k2), t)
        rel = np.abs(y2 - y1) / y1
        pa, pb, ea = max(pa, rel.max()), max(pb, rel[t <= 0.9].max()), max(ea, np.abs(e2 - e1).max())
    return pa, pb, ea


def gasturb_round_trip() -> None:
    """Per GasTurb/GSP map file shipped with GSPy (tests/solvers/perfmap/data/gasturb): the settings read, the worst
    excess of a line's pressure error over its floor, the fit's stated error, then per beta grid (21 evenly spaced:
    the grid before; 21 and 40 adaptive: after) the table error the result states, the map read back from the .map
    export against the file's points (read linearly between beta nodes; bound: fit error + table error of the line),
    and the read-back map fitted again against the first fit (bound: table error + the refit's own error); CPU
    seconds of the grid (tabulate)."""
    from plantsolve.solvers.base import InputRejected
    from plantsolve.solvers.perfmap.beta_grid import tabulate
    from plantsolve.solvers.perfmap.cycle_exports import gasturb_tables
    from plantsolve.solvers.perfmap.validation import loaded

    data = Path(__file__).resolve().parents[1] / "tests" / "solvers" / "perfmap" / "data" / "gasturb"
    print("\nGSPy's GasTurb/GSP maps: in -> fit -> .map out -> in (pressure, relative; CPU s)")
    print(f"{'map':12s} {'lines':>5s} {'excess':>7s} {'fit err':>7s} | {'beta grid':>12s} {'grid s':>6s} "
          f"{'table err':>9s} | {'read back vs file':>17s} {'bound':>6s} | {'refit vs fit':>12s} {'bound':>6s}")
    for path in sorted(data.glob("*.map")):
        for lines, spacing in ((21, "even"), (21, "adaptive"), (40, "adaptive")):
            options = {"map": False, "beta_grid": {"lines": lines, "spacing": spacing}}
            try:
                req = parse_upload(StoredInput.from_bytes(path.name, path.read_bytes()), options)
            except InputRejected as e:
                print(f"{path.name:12s} refused: {e.errors[0].msg[:90]}")
                break
            res = solve(req).result
            curves = curveset_from_fits(res.settings)
            c0 = time.process_time()
            tabulate(curves, lines, "parabola", True, spacing)
            grid_s = time.process_time() - c0
            fits = {tuple(x.setting): x for x in res.settings}
            tables = {tuple(x.setting): x for x in res.beta_map.lines}
            (text,) = gasturb_tables(res).values()
            back = parse_upload(StoredInput.from_bytes("again.map", text), {"map": False})
            read_back = {tuple(p.setting): p for p in back.positions}
            vs_file = bound_file = 0.0
            for st in loaded(req).settings:
                p = read_back[st.values]
                order = np.argsort(p.flow)
                err = np.max(np.abs(np.interp(st.x, np.array(p.flow)[order], np.array(p.pressure)[order]) - st.y)
                             / st.y)
                vs_file = max(vs_file, err)
                bound_file = max(bound_file, fits[st.values].pressure_max_rel_error
                                 + tables[st.values].table_pressure_max_rel_error)
            again = solve(back).result
            refit, _, _ = agree(res, again)
            bound_refit = max(tables[tuple(x.setting)].table_pressure_max_rel_error + x.pressure_max_rel_error
                              for x in again.settings)
            print(f"{path.name:12s} {len(res.settings):5d} {100 * max(x.pressure_excess for x in res.settings):6.2f}% "
                  f"{100 * max(x.pressure_max_rel_error for x in res.settings):6.2f}% | {lines:3d} {spacing:8s} "
                  f"{grid_s:6.3f} {100 * res.beta_map.table_pressure_max_rel_error:8.2f}% | {100 * vs_file:16.2f}% "
                  f"{100 * bound_file:5.2f}% | {100 * refit:11.2f}% {100 * bound_refit:5.2f}%")


def beta_export() -> None:
    """Per pyCycle map: the beta grid and the cycle-code exports. CPU seconds (``time.process_time``) of the solve
    without a map (which includes the beta grid), of the grid alone and of writing the three exports; then the
    round trip: each export read back by the upload reader and fitted again, against the fitted map (pressure at
    the same flow, relative, on the whole line and on its first 90 %; efficiency absolute), for 21 evenly spaced
    beta lines (the grid before), 21 and 40 adaptive ones (the default spacing); and the known-answer check
    (closed-form speed lines, parabolic surge/choke lines)."""
    import resource

    from plantsolve.schemas.perfmap import BetaGridOption
    from plantsolve.solvers.perfmap.artifacts import cycle_code_artifacts
    from plantsolve.solvers.perfmap.beta_grid import tabulate

    data = Path(__file__).resolve().parents[1] / "tests" / "solvers" / "perfmap" / "data" / "pycycle"
    print("\nBeta grid and cycle-code exports on pyCycle's maps (CPU s; round trip = export read back and fitted "
          "again: pressure rel. err. at the same flow, whole line / first 90 %, efficiency abs. err.)")
    print(f"{'map':14s} {'lines':>5s} {'beta':>13s} | {'solve s':>7s} {'grid s':>7s} {'export s':>8s} | "
          f"{'table err':>9s} | {'pyCycle p all/body':>19s} {'eta':>8s} | {'CSV p all/body':>15s} {'eta':>8s}")
    for path in sorted(data.glob("*.py")):
        for n, spacing in ((21, "even"), (21, "adaptive"), (40, "adaptive")):
            req = parse_upload(StoredInput.from_bytes(path.name, path.read_bytes()), {"map": False})
            req = req.model_copy(update={"options": req.options.model_copy(
                update={"beta_grid": BetaGridOption(lines=n, spacing=spacing)})})
            c0 = time.process_time()
            res = solve(req).result
            c1 = time.process_time()
            tabulate(curveset_from_fits(res.settings), n, "parabola", True, spacing)
            c2 = time.process_time()
            arts = {a.name: a.data for a in cycle_code_artifacts(res)}
            c3 = time.process_time()
            row = []
            for name in ("map_pycycle.py", "map_beta.csv"):
                again = solve(parse_upload(StoredInput.from_bytes(name, arts[name]), {"map": False})).result
                pa, pb, ea = agree(res, again)
                row.append(f"{100 * pa:8.2f}% /{100 * pb:6.2f}% {ea:8.1e}")
            print(f"{path.stem:14s} {len(res.settings):5d} {n:4d} {spacing:8s} | {c1 - c0:7.2f} {c2 - c1:7.3f} "
                  f"{c3 - c2:8.3f} | {100 * res.beta_map.table_pressure_max_rel_error:8.2f}% | "
                  f"{row[0]} | {row[1][:-9]:>15s} {row[1][-8:]}")
    # known answer: PR = a - 0.02 Wc^2 between the parabolas PR - 1 = 0.05 Wc^2 (surge) and 0.01 Wc^2 (choke)
    worst = 0.0
    positions, lines = [], []
    for a, n in zip((1.6, 2.2, 3.0, 4.0), (0.6, 0.7, 0.8, 0.9)):
        xs, xc = np.sqrt((a - 1) / (0.02 + np.array([0.05, 0.01])))
        x = np.linspace(xs, xc, 7)
        positions.append({"setting": [n], "flow": x.tolist(), "pressure": (a - 0.02 * x * x).tolist(),
                          "efficiency": (0.9 - 0.1 * (x - x.mean()) ** 2 / (xc - xs) ** 2).tolist()})
        lines.append(a)
    res = solve(PerfmapRequest.model_validate({"setting_names": ["Nc"], "units": {"pressure": "1"}, "positions": positions,
                                               "options": {"map": False, "model": "parabola",
                                                           "beta_grid": {"spacing": "even"}}})).result
    beta = np.array(res.beta_map.beta)
    for a, line in zip(lines, res.beta_map.lines):
        x = np.sqrt((a - 1) / (0.02 + 0.01 + beta * 0.04))
        worst = max(worst, np.max(np.abs(np.array(line.flow) - x) / x))
    print(f"known answer (closed-form parabolic beta lines, 4 lines x 21 betas): max rel. flow error {worst:.1e}")
    print(f"peak RSS {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} MB")


if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--pycycle", action="store_true", help="only the pyCycle maps against their floors")
    ap.add_argument("--export", action="store_true", help="only the beta grid and cycle-code exports")
    ap.add_argument("--gasturb", action="store_true", help="only GSPy's GasTurb/GSP maps and their .map round trip")
    args = ap.parse_args()
    if args.gasturb:
        gasturb_round_trip()
        sys.exit()
    if not args.export:
        if not args.pycycle:
            main(args)
            pressure_reach()
        pycycle_floor()
    beta_export()
    gasturb_round_trip()
