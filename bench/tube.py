"""Benchmark of the tube solver on simulated single-view laser scans.

    python bench/tube.py           # 40 random tubes + 100k and 1M point runs
    python bench/tube.py --quick   # 12 random tubes + 100k point run
    python bench/tube.py --families 50   # only the hard scenario families (short arcs, small bends far
                                         # apart, nearly coplanar back-to-back bends)
    python bench/tube.py --families 20 --radius-models auto,per_bend   # also with one free radius per bend
    python bench/tube.py --before-after 10 [--ref main]   # every family, main's solver vs this tree's
    python bench/tube.py --scale 3e5,1.2e6,3e6,1e7,3e7 [--ref main] [--ref-max 1e7] [--heap]   # large scans, main's
                                         # solver vs this tree's, CPU seconds and peak RSS of a fresh process each
                                         # (--heap: this tree's also with freed memory kept in glibc's heap)

Scan simulator (plantsolve/solvers/tube/synthetic.py): one viewpoint, area-correct sampling, Gaussian
noise of 1–1.5 % of the pipe radius along the normal, 0.5 % uniform outliers; random tubes
with pipe radius 1–50 mm, 1–8 bends, bend radius 2–4 r, back-to-back bends, bends under 8°
and over 180°. Timings and peak memory for large scans run in a fresh subprocess each.
"""

from __future__ import annotations

import argparse
import itertools
import json
import os

# CPU seconds of one solver thread, as the workers run it (they set these too)
for _name in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")
import resource
import subprocess
import sys
import time

# --before-after solves the same cases with another revision's solver: its sources come first on the path
sys.path.insert(0, os.environ.get("TUBE_BENCH_CODE") or os.path.join(os.path.dirname(__file__), ".."))

import numpy as np  # noqa: E402

from plantsolve.schemas.tube import TubeRequest  # noqa: E402
from plantsolve.solvers.base import SolverError, StoredInput  # noqa: E402
from plantsolve.solvers.tube.solve import solve  # noqa: E402
from plantsolve.solvers.tube.upload import parse_upload  # noqa: E402
from plantsolve.solvers.tube.artifacts import model_from_result  # noqa: E402
from plantsolve.solvers.tube.model import build_spine, reverse_model, sample_centreline, spine_distance  # noqa: E402
from plantsolve.solvers.tube.synthetic import clear_tube, surface_samples  # noqa: E402


def make_case(seed: int, n_points: int, n_bends: int | None = None, pipe_radius: float | None = None):
    rng = np.random.default_rng(seed)
    m = clear_tube(rng, pipe_radius=pipe_radius, n_bends=n_bends)
    sigma = rng.uniform(0.01, 0.015) * m.pipe_radius
    view = rng.normal(size=3)
    pts = surface_samples(m, n_points, rng, view=view, noise=sigma, outlier_fraction=0.005)
    return m, pts, sigma


MAKE_ALONE = 1_000_000  # --make draws scans up to this size in one call (make_case's scan)
MAKE_CHUNK = 250_000  # and larger ones this many samples at a time


def make_scan(n_points: int, path: str) -> None:
    """The scan of --make (the tube of ``make_case(77, ...)``: 4 bends, pipe radius 10) saved to the .npy at
    ``path``. Up to ``MAKE_ALONE`` samples it is make_case's scan; a larger one is drawn ``MAKE_CHUNK`` samples
    at a time (each chunk with its own seed, noise and outliers as make_case's) straight into the file, so
    the simulator's temporaries are one chunk's (one call for 10 million samples would hold about 20 GB). The solver sorts its input, so the chunks need no shuffle."""
    if n_points <= MAKE_ALONE:
        _, pts, _ = make_case(77, n_points, n_bends=4, pipe_radius=10.0)
        np.save(path, pts)
        return
    rng = np.random.default_rng(77)
    m = clear_tube(rng, pipe_radius=10.0, n_bends=4)  # make_case's draws, in its order: the same tube, noise, view
    sigma = rng.uniform(0.01, 0.015) * m.pipe_radius
    view = rng.normal(size=3)
    out = np.lib.format.open_memmap(path, mode="w+", dtype=np.float64, shape=(n_points, 3))
    for i, a in enumerate(range(0, n_points, MAKE_CHUNK)):
        b = min(a + MAKE_CHUNK, n_points)
        out[a:b] = surface_samples(m, b - a, np.random.default_rng([77, i]), view=view, noise=sigma,
                                   outlier_fraction=0.005)
    out.flush()
    del out


def compare(truth, result):
    """Errors of a result against the true model walked the way the solver walked it: of the truth and the truth
    reversed (with the result's bend count), the one whose segments start and end nearer the result's, segment
    by segment. (By the bend angles alone the two directions tie on a tube of one bend, or of angles that read
    the same both ways: the truth's own direction then won, and its end straights were compared with the
    result's opposite ends.)"""
    got = model_from_result(result)
    got_sp = build_spine(got)
    best = None
    for t in (truth, reverse_model(truth)):
        if t.n_bends != got.n_bends:
            continue
        da = np.degrees(np.abs(got.angles - t.angles))
        dr = np.abs(got.radii - t.radii) / t.radii
        sp = build_spine(t)
        key = float(np.linalg.norm(sp.start - got_sp.start, axis=1).sum() + np.linalg.norm(sp.end - got_sp.end,
                                                                                           axis=1).sum())
        if best is None or key < best[0]:
            best = (key, da, dr, t)
    c, _ = sample_centreline(got, truth.pipe_radius / 4)
    dc, _ = spine_distance(c, build_spine(truth))
    if best is None:
        return None, None, None, dc
    return best[1], best[2], best[3], dc


def sigma_check(result, t):
    """|error| / reported sigma of every bend angle and radius (t: the truth in the result's walking
    direction), the median relative radius sigma and the bends flagged ``bend_radius_undetermined``."""
    got = model_from_result(result)
    rows = result.lra[:-1]
    za = [np.degrees(abs(got.angles[k] - t.angles[k])) / max(rows[k].sigma_angle, 1e-300) for k in range(len(rows))]
    zr = [abs(got.radii[k] - t.radii[k]) / max(rows[k].sigma_bend_radius, 1e-300) for k in range(len(rows))]
    rel_sigma = [rows[k].sigma_bend_radius / rows[k].bend_radius for k in range(len(rows))]
    undet = set()
    for w in result.report.warnings:
        if w.code == "bend_radius_undetermined":
            undet |= {b["bend"] - 1 for b in w.details["bends"]}
    return za, zr, rel_sigma, undet


def random_tubes(n_tubes: int, n_points: int, seed0: int = 1000):
    rows = []
    for i in range(n_tubes):
        m, pts, sigma = make_case(seed0 + i, n_points)
        t0 = time.perf_counter()
        try:
            r = solve(TubeRequest(points=pts.tolist())).result
        except SolverError as exc:
            print(f"  tube {i:2d}: r={m.pipe_radius:6.2f} bends {m.n_bends} -> failed: {exc}", flush=True)
            rows.append(dict(ok=False, failed=True, time=time.perf_counter() - t0))
            continue
        el = time.perf_counter() - t0
        da, dr, t, dc = compare(m, r)
        # residual spread of the inliers relative to the simulated noise
        got = model_from_result(r)
        d, _ = spine_distance(pts, build_spine(got))
        res = d - got.pipe_radius
        inl = np.ones(len(pts), bool)
        inl[r.outliers.indices] = False
        rs = 1.4826 * np.median(np.abs(res[inl] - np.median(res[inl])))
        rows.append(dict(
            r=m.pipe_radius, bends=m.n_bends, got=len(r.lra) - 1, ok=da is not None, time=el,
            angle_err=(da.tolist() if da is not None else []), radius_err=(dr.tolist() if dr is not None else []),
            small=((np.degrees(t.angles) < 10).tolist() if da is not None else []), centre_rms=float(np.sqrt(np.mean(dc ** 2)) / m.pipe_radius),
            centre_max=float(dc.max() / m.pipe_radius), resid_sigma=float(rs / sigma),
            resid_median=float(np.median(np.abs(res[inl])) / sigma), pr_err=abs(r.pipe_radius - m.pipe_radius) / m.pipe_radius,
            z=(np.concatenate(sigma_check(r, t)[:2]).tolist() if da is not None else [])))
        print(f"  tube {i:2d}: r={m.pipe_radius:6.2f} bends {m.n_bends} -> {len(r.lra) - 1}"
              f"  max angle err {max(rows[-1]['angle_err'], default=float('nan')):.3f}°"
              f"  centreline rms {100 * rows[-1]['centre_rms']:.2f}% r  {el:.2f}s", flush=True)
    return rows


def single(path: str) -> dict:
    """One large scan, read from an .npy file the way an upload is (``parse_upload``), solved
    in this fresh process so that the peak RSS is the solver's, not the simulator's."""
    n_points = int(path.rsplit("_", 1)[1].split(".")[0])
    m, _, _ = make_case(77, 1000, n_bends=4, pipe_radius=10.0)  # same tube, few points: the truth
    req = parse_upload(StoredInput.from_path(path, "scan.npy"), None)
    t0 = time.perf_counter()
    r = solve(req).result
    el = time.perf_counter() - t0
    da, dr, _, dc = compare(m, r)
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    return dict(n=n_points, time=el, rss_mb=rss, ok=da is not None,
                angle_err=float(np.max(da)) if da is not None else None,
                centre_rms=float(np.sqrt(np.mean(dc ** 2)) / m.pipe_radius),
                timings=r.report.details["timings_s"])


def run_single(n: int) -> dict:
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, f"scan_{n}.npy")
        subprocess.run([sys.executable, __file__, "--make", str(n), path], check=True)
        out = subprocess.run([sys.executable, __file__, "--single", path], capture_output=True, text=True,
                             check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def family_tube(family: str, seed: int):
    """A tube of one of the hard scenario families (each bent on one die, so radii are shared):
    short_arc: 3-5 bends of 12-22 degrees on a 2.4 r die (arcs shorter than the pipe radius);
    small_far: two bends of 3-5 degrees 6-8 r apart with 30-60 degrees of rotation between them;
    b2b_coplanar: two bends of 90-115 degrees with 0.15-0.3 r of straight and under 1.5 degrees of
    rotation between them; small_bends: seven bends on a 3 r die, three of them 3.6-5 degrees, straights
    of 3-9 r, pipe radius 20 (``synthetic.small_bends_tube``). 6000 single-view samples, noise 1.2 % of r,
    0.5 % outliers."""
    from plantsolve.solvers.tube.synthetic import make_model, random_rotation, small_bends_tube

    rng = np.random.default_rng(seed)
    if family == "small_bends":
        m = small_bends_tube(rng)
        pts = surface_samples(m, 6000, rng, view=rng.normal(size=3), noise=0.012 * m.pipe_radius,
                              outlier_fraction=0.005)
        return m, pts
    rp = float(rng.uniform(3.0, 20.0))
    if family == "short_arc":
        die = 2.4 * rp
        n = int(rng.integers(3, 6))
        rows = [(rng.uniform(4, 8) * rp, rng.uniform(-180, 180) if k else 0.0, rng.uniform(12, 22), die)
                for k in range(n)] + [(rng.uniform(4, 8) * rp, rng.uniform(-180, 180), 0.0, 0.0)]
    elif family == "small_far":
        die = rng.uniform(12, 20) * rp
        rows = [(6 * rp, 0.0, rng.uniform(3, 5), die), (rng.uniform(6, 8) * rp, rng.uniform(30, 60), rng.uniform(3, 5), die),
                (6 * rp, 0.0, 0.0, 0.0)]
    else:
        die = rng.uniform(2.5, 3.5) * rp
        rows = [(5 * rp, 0.0, rng.uniform(90, 115), die), (rng.uniform(0.15, 0.3) * rp, rng.uniform(-1.5, 1.5),
                                                            rng.uniform(90, 115), die), (5 * rp, 0.0, 0.0, 0.0)]
    m = make_model(rows, rp, start=rng.normal(size=3) * 10 * rp, frame=random_rotation(rng))
    pts = surface_samples(m, 6000, rng, view=rng.normal(size=3), noise=0.012 * rp, outlier_fraction=0.005)
    return m, pts


FAMILIES = ("short_arc", "small_far", "b2b_coplanar", "small_bends")


def families(n_tubes: int, radius_models: tuple[str, ...] = ("auto",)) -> None:
    """Per hard family and radius model ('auto': chosen by the data; 'per_bend': one free radius per bend).

    Radius errors are given over all bends and over the bends whose radius the solver reports as
    determined (no ``bend_radius_undetermined`` warning); 'undetermined' counts the flagged bends.
    'radius σ' is the reported standard deviation relative to the radius (what the data can resolve);
    'within 2σ' is the share of reported sigmas (angle and radius) that cover the truth."""
    print(f"hard scenario families: {n_tubes} tubes each, 6000 points")
    print("| family | radius model | bend count ok | angle err median / p95 | radius err median / p95 / max "
          "(all bends) | radius err median / p95 / max (determined) | radius σ median | undetermined bends | within 2σ "
          "(angle, radius) | centreline rms (median, % r) | chosen | time median s |")
    print("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---|---:|")
    for family in FAMILIES:
        for model in radius_models:
            ok, ang, rad, rad_det, n_undet, n_bends, za, zr, rsig, crms, chosen, times = 0, [], [], [], 0, 0, [], [], [], [], {}, []
            for i in range(n_tubes):
                truth, pts = family_tube(family, 5000 + i)
                req = TubeRequest.model_validate({"points": pts.tolist(),
                                                  "options": {"bend_radius_model": model}})
                t0 = time.perf_counter()
                try:
                    res = solve(req).result
                except SolverError:
                    times.append(time.perf_counter() - t0)
                    continue
                times.append(time.perf_counter() - t0)
                da, dr, t, dc = compare(truth, res)
                crms.append(float(np.sqrt(np.mean(dc ** 2)) / truth.pipe_radius))
                if res.bend_radius_model is not None:
                    chosen[res.bend_radius_model.chosen] = chosen.get(res.bend_radius_model.chosen, 0) + 1
                if da is None:
                    continue
                ok += 1
                ang += list(da)
                rad += list(dr)
                za_k, zr_k, sr_k, undet = sigma_check(res, t)
                n_undet += len(undet)
                n_bends += len(dr)
                rad_det += [e for k, e in enumerate(dr) if k not in undet]
                za += za_k
                zr += zr_k
                rsig += sr_k
            ang, rad, rad_det, za, zr, rsig = map(np.array, (ang, rad, rad_det, za, zr, rsig))
            q = lambda a, f: f"{f(a):.3f}" if len(a) else "n/a"
            p95 = lambda a: np.percentile(a, 95)
            cov = lambda z: f"{100 * np.mean(z <= 2):.0f} %" if len(z) else "n/a"
            print(f"| {family} | {model} | {ok}/{n_tubes} | {q(ang, np.median)}° / {q(ang, p95)}° "
                  f"| {q(100 * rad, np.median)} / {q(100 * rad, p95)} / {q(100 * rad, np.max)} % "
                  f"| {q(100 * rad_det, np.median)} / {q(100 * rad_det, p95)} / {q(100 * rad_det, np.max)} % "
                  f"| {q(100 * rsig, np.median)} % | {n_undet}/{n_bends} | {cov(za)}, {cov(zr)} "
                  f"| {100 * np.median(crms):.2f} | {', '.join(f'{k} {v}' for k, v in sorted(chosen.items()))} "
                  f"| {np.median(times):.2f} |", flush=True)


def _case(family: str, seed: int):
    if family == "random":
        m, pts, _ = make_case(seed, 6000)
        return m, pts
    return family_tube(family, seed)


def solve_cases(path: str) -> None:
    """Child of --before-after: solves the cases of the .npz at ``path`` whose names it reads on stdin, one per
    line, with the solver on the path; one JSON line per case (bend count, worst radius and angle errors against
    the truth, CPU seconds), and on end of input its peak RSS."""
    from plantsolve.solvers.tube.synthetic import make_model

    data = np.load(path)
    for line in sys.stdin:
        name = line.strip()
        rows, pts = data[name + "/rows"], data[name + "/pts"]
        truth = make_model(rows, float(data[name + "/rp"]), start=data[name + "/start"], frame=data[name + "/frame"])
        t0 = time.process_time()
        try:
            res = solve(TubeRequest(points=pts.tolist())).result
        except SolverError:
            print(json.dumps({"case": name, "got": -1, "cpu": time.process_time() - t0}), flush=True)
            continue
        cpu = time.process_time() - t0
        da, dr, t, _ = compare(truth, res)
        big = np.degrees(t.angles) >= 10 if da is not None else None
        if da is not None:  # end straights: the ones the sample extent sets, in pipe radii
            got = model_from_result(res)
            end_err = float(np.abs(got.lengths[[0, -1]] - t.lengths[[0, -1]]).max() / t.pipe_radius)
        print(json.dumps({"case": name, "got": len(res.lra) - 1, "cpu": cpu,
                          "angle": float(da.max()) if da is not None else None,
                          "radius": float(dr.max()) if da is not None else None,
                          "radius_big": float(dr[big].max()) if da is not None and big.any() else None,
                          "end": end_err if da is not None else None,
                          "ends": sorted([res.lra[0].length, res.lra[-1].length]),
                          "codes": [w.code for w in res.report.warnings]}), flush=True)
    print(json.dumps({"peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}), flush=True)


def before_after(n_tubes: int, ref: str, n_random: int | None = None, repeat: int = 1) -> None:
    """Every family (the random tubes too), n_tubes seeds each (``n_random`` random tubes when given), solved by
    the solver of git revision ``ref`` and by this tree's, each side in its own process on the same saved
    samples, case by case in turn, each case ``repeat`` times (the least CPU time kept)."""
    import tempfile

    repo = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
    fams = ("random",) + FAMILIES
    with tempfile.TemporaryDirectory() as tmp:
        arrays, truth_n = {}, {}
        for fam in fams:
            for i in range(n_random if fam == "random" and n_random is not None else n_tubes):
                m, pts = _case(fam, (1000 if fam == "random" else 5000) + i)
                name = f"{fam}-{i:03d}"
                truth_n[name] = m.n_bends
                arrays.update({f"{name}/rows": np.column_stack([m.lengths, np.degrees(m.rotations), np.degrees(
                    np.append(m.angles, 0.0)), np.append(m.radii, 0.0)]), f"{name}/pts": pts,
                    f"{name}/rp": m.pipe_radius, f"{name}/start": m.start, f"{name}/frame": m.frame})
        cases = os.path.join(tmp, "cases.npz")
        np.savez(cases, **arrays)
        before_code = os.path.join(tmp, "before")
        os.makedirs(before_code)
        archive = subprocess.run(["git", "-C", repo, "archive", ref, "plantsolve"], capture_output=True, check=True)
        subprocess.run(["tar", "-x", "-C", before_code], input=archive.stdout, check=True)
        # both solvers in their own process, fed the same case in turn (``repeat`` rounds, the least CPU time of
        # each case kept): drift in the machine's load then hits both sides alike
        labels = (f"before ({ref})", "after (this tree)")
        procs = [subprocess.Popen([sys.executable, __file__, "--solve-cases", cases], stdin=subprocess.PIPE,
                                  stdout=subprocess.PIPE, text=True, env={**os.environ, "TUBE_BENCH_CODE": code})
                 for code in (before_code, "")]
        sides: dict[str, list[dict]] = {label: [] for label in labels}
        for name in sorted(truth_n):
            for side in range(repeat):
                for label, proc in zip(labels if side % 2 == 0 else labels[::-1],
                                       procs if side % 2 == 0 else procs[::-1]):
                    proc.stdin.write(name + "\n")
                    proc.stdin.flush()
                    row = json.loads(proc.stdout.readline())
                    kept = sides[label]
                    if kept and kept[-1]["case"] == name:
                        kept[-1]["cpu"] = min(kept[-1]["cpu"], row["cpu"])
                    else:
                        kept.append(row)
        peak = {}
        for label, proc in zip(labels, procs):
            out, _ = proc.communicate("")
            peak[label] = max((json.loads(x)["peak_rss_mb"] for x in out.splitlines() if "peak_rss_mb" in x),
                              default=float("nan"))
    print(f"before / after: {n_tubes} tubes per family ({n_random if n_random is not None else n_tubes} random), "
          "6000 points; CPU s = time.process_time() of the solve in one process per side, the sides solving each "
          f"case in turn, least of {repeat} run(s); radius error = worst |R - R_true| / R_true over the tubes with "
          "the right bend count")
    print("| family | solver | bend count correct | worst radius err (all bends) | worst radius err (bends >= 10°) "
          "| worst angle err | worst end straight err (% r) | CPU s median / worst / total |")
    print("|---|---|---:|---:|---:|---:|---:|---:|")
    accuracy: dict[str, list[str]] = {side: [] for side in sides}  # each side's accuracy columns, as printed
    for fam in fams:
        for side, rows in sides.items():
            rows = [r for r in rows if r["case"].startswith(fam + "-")]
            if not rows:  # a family asked for none (--random-tubes 0)
                continue
            ok = [r for r in rows if r["got"] == truth_n[r["case"]]]
            worst = {key: max((r[key] for r in ok if r[key] is not None), default=None)
                     for key in ("radius", "radius_big", "angle", "end")}
            pct = {key: f"{100 * v:.1f} %" if v is not None else "n/a" for key, v in worst.items()}
            cpu = np.array([r["cpu"] for r in rows])
            columns = (f"| {len(ok)}/{len(rows)} = {100 * len(ok) / max(len(rows), 1):.0f} % "
                       f"| {pct['radius']} | {pct['radius_big']} "
                       f"| {worst['angle'] if worst['angle'] is not None else float('nan'):.3f}° "
                       f"| {100 * worst['end'] if worst['end'] is not None else float('nan'):.4f} ")
            accuracy[side].append(columns)
            print(f"| {fam} | {side} {columns}| {np.median(cpu):.2f} / {cpu.max():.2f} / {cpu.sum():.1f} |", flush=True)
    trust_table(sides, truth_n, fams)
    before, after = ({r["case"]: r for r in rows} for rows in sides.values())
    moved = {c: abs(np.subtract(before[c]["ends"], after[c]["ends"])).max() for c in before
             if c in after and "ends" in before[c] and "ends" in after[c] and before[c]["ends"] != after[c]["ends"]}
    print("peak RSS of each side's process (all its cases): " + ", ".join(f"{side} {v:.0f} MiB" for side, v in peak.items()))
    # the contract of a speed-up: these columns the same on both sides
    print("accuracy columns the same on both sides: " + ("yes" if len({tuple(v) for v in accuracy.values()}) == 1
                                                         else "NO"))
    print(f"cases whose end straight lengths differ between the sides: {len(moved)}/{len(before)}"
          + "".join(f"; {c}: {d:.3g}" for c, d in sorted(moved.items())))


FLAT_WINDOW = 10  # --lm-trace: the cost's decrease over this many last evaluations of a round


def lm_trace(name: str) -> None:
    """Every Levenberg–Marquardt round of one --before-after case (``family-NNN``): its parameters and samples,
    evaluation limit and use, accepted steps, why it stopped, and how much its cost still moved over its last
    ``FLAT_WINDOW`` evaluations, relatively and times its samples (≈ Δχ², the cost being about N σ²: a change
    of 1 moves a parameter about one standard deviation). A round at its limit with a Δχ² well above 0.01
    was still moving its answer when it stopped: a stopping rule on a flat cost cannot end it sooner."""
    from plantsolve.solvers.tube import fit

    fam, i = name.rsplit("-", 1)
    _, pts = _case(fam, (1000 if fam == "random" else 5000) + int(i))
    rounds = []
    lm = fit.levenberg_marquardt

    def traced(fun, normal_equations, x0, lo, hi, f_scale, max_nfev=60, *args, **kwargs):
        costs, n = [], []

        def fun_costed(x, out=None):  # the residuals the solver asked for, their cost noted on the side
            r = fun(x, out=out)
            costs.append(fit._soft_l1(r, f_scale)[0])
            n[:] = [len(r)]
            return r

        x, info = lm(fun_costed, normal_equations, x0, lo, hi, f_scale, max_nfev, *args, **kwargs)
        rounds.append((len(x0), n[0] if n else 0, max_nfev, costs, info))
        return x, info

    fit.levenberg_marquardt = traced
    try:
        t0 = time.process_time()
        solve(TubeRequest(points=pts.tolist()))
        cpu = time.process_time() - t0
    finally:
        fit.levenberg_marquardt = lm
    print(f"LM rounds of {name} ({cpu:.2f} CPU s with the tracing)")
    print(f"| round | parameters | samples | limit | evaluations | accepted | stopped | cost decrease over the last "
          f"{FLAT_WINDOW} evaluations | × samples (≈ Δχ²) |")
    print("|---:|---:|---:|---:|---:|---:|---|---:|---:|")
    at_limit = 0
    for k, (P, N, limit, costs, info) in enumerate(rounds, 1):
        best = np.minimum.accumulate(costs)
        accepted = int(np.count_nonzero(np.asarray(costs[1:]) <= best[:-1]))
        stop = "limit" if info["nfev"] >= limit else {2: "converged", 3: "no descent"}.get(info["status"], "?")
        at_limit += stop == "limit"
        w = min(FLAT_WINDOW, len(best) - 1)
        rel = (best[-1 - w] - best[-1]) / best[-1] if w > 0 else 0.0
        print(f"| {k} | {P} | {N} | {limit} | {info['nfev']} | {accepted} | {stop} | {rel:.1e} | {rel * N:.3g} |")
    print(f"{at_limit}/{len(rounds)} rounds stopped at their evaluation limit, "
          f"{sum(r[4]['nfev'] for r in rounds)} evaluations in all")


# a wrong answer: the wrong bend count, or with the right count a bend angle this many degrees off
WRONG_ANGLE_DEG = 5.0


def trust_table(sides: dict[str, list[dict]], truth_n: dict[str, int], fams: tuple[str, ...]) -> None:
    """Per family and side: the wrong answers (bend count, or a bend angle over ``WRONG_ANGLE_DEG`` off) and how
    many of them carry the warning ``bend_count_uncertain`` (recall), and the right answers that carry it
    (false alarms)."""
    print(f"wrong answers (bend count wrong, or a bend angle over {WRONG_ANGLE_DEG:g}° off) with the warning "
          "bend_count_uncertain, and right answers with it")
    print("| family | solver | wrong answers warned | right answers warned | wrong answers unwarned |")
    print("|---|---|---:|---:|---|")
    for fam in fams:
        for side, rows in sides.items():
            rows = [r for r in rows if r["case"].startswith(fam + "-") and r["got"] >= 0]
            wrong = [r for r in rows if r["got"] != truth_n[r["case"]] or r["angle"] > WRONG_ANGLE_DEG]
            right = [r for r in rows if r not in wrong]
            warned = lambda rs: [r for r in rs if "bend_count_uncertain" in r.get("codes", ())]
            missed = [r["case"] for r in wrong if r not in warned(wrong)]
            print(f"| {fam} | {side} | {len(warned(wrong))}/{len(wrong)} | {len(warned(right))}/{len(right)} "
                  f"| {', '.join(missed) or '—'} |", flush=True)


def scale_one(path: str) -> None:
    """Child of --scale: solve the scan at ``path`` with the solver on the path. The samples go to the solver
    as an array (an upload holds at most 5 million points, ``MAX_POINTS``); prints CPU seconds of the solve,
    the peak RSS of this process and the errors against the truth."""
    from plantsolve.solvers.tube.scan import TubeScan

    pts = np.load(path)
    pts.setflags(write=False)
    m, _, _ = make_case(77, 1000, n_bends=4, pipe_radius=10.0)  # the tube of --make: the truth
    scan = TubeScan(TubeRequest(points=pts[:100].tolist()))
    scan.__dict__["points"] = pts  # the cached decoded samples
    ru0 = resource.getrusage(resource.RUSAGE_SELF)
    t0 = time.process_time()
    r = solve(scan).result
    cpu = time.process_time() - t0
    sys_s = resource.getrusage(resource.RUSAGE_SELF).ru_stime - ru0.ru_stime
    da, _, _, dc = compare(m, r)
    print(json.dumps({"n": len(pts), "cpu": cpu, "sys": sys_s,
                      "rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
                      "bends_ok": da is not None, "angle_err": float(np.max(da)) if da is not None else None,
                      "centre_rms": float(np.sqrt(np.mean(dc ** 2)) / m.pipe_radius),
                      "ends": sorted([r.lra[0].length, r.lra[-1].length]),
                      "true_ends": sorted(m.lengths[[0, -1]].tolist())}), flush=True)


# glibc's malloc hands every block above its mmap threshold (at most 32 MiB) to fresh pages of the kernel and gives
# them back when freed: from about 4 million samples each array of a scan's size is such a block, faulted in anew
# (zeroed) each time. With these the freed blocks stay in the heap for the next one (what --heap measures).
HEAP_KEPT = {"MALLOC_MMAP_THRESHOLD_": str(2 ** 32), "MALLOC_TRIM_THRESHOLD_": str(2 ** 36)}


def scale(sizes: list[int], ref: str, ref_max: int, heap: bool = False) -> None:
    """Large scans of the --make tube (4 bends, pipe radius 10), each solved in a fresh process by the solver
    of git revision ``ref`` (up to ``ref_max`` points) and by this tree's; with ``heap`` this tree's once more in
    a process whose freed memory stays in glibc's heap (``HEAP_KEPT``)."""
    import tempfile

    repo = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        before_code = os.path.join(tmp, "before")
        os.makedirs(before_code)
        archive = subprocess.run(["git", "-C", repo, "archive", ref, "plantsolve"], capture_output=True, check=True)
        subprocess.run(["tar", "-x", "-C", before_code], input=archive.stdout, check=True)
        for n in sizes:
            path = os.path.join(tmp, f"scan_{n}.npy")
            subprocess.run([sys.executable, __file__, "--make", str(n), path], check=True)
            sides = [(f"before ({ref})", before_code, {}), ("after (this tree)", "", {})]
            if heap:
                sides.append(("after, heap kept", "", HEAP_KEPT))
            for side, code, extra in sides:
                if code and n > ref_max:
                    continue
                env = {**os.environ, "TUBE_BENCH_CODE": code, **extra}
                out = subprocess.run([sys.executable, __file__, "--scale-one", path], capture_output=True, text=True,
                                     check=True, env=env)
                rows.append({"side": side, **json.loads(out.stdout.strip().splitlines()[-1])})
                print(f"  {n:,} points, {side}: {rows[-1]['cpu']:.1f} s CPU", flush=True)
            os.remove(path)
    print("large scans (4 bends, pipe radius 10, noise 1-1.5 % r, 0.5 % outliers); CPU s = time.process_time() of "
          "the solve, one solver thread; peak RSS of the fresh process (samples loaded as an array)")
    print("| points | solver | CPU s (of it system) | peak RSS MiB | bend count ok | max angle err | centreline rms (% r) "
          "| end straights (true) mm |")
    print("|---:|---|---:|---:|---|---:|---:|---|")
    for r in sorted(rows, key=lambda r: (r["n"], r["side"])):
        err = f"{r['angle_err']:.4f}°" if r["angle_err"] is not None else "n/a"
        ends = " / ".join(f"{v:.6f}" for v in r.get("ends", []))
        true_ends = " / ".join(f"{v:.2f}" for v in r.get("true_ends", []))
        print(f"| {r['n']:,} | {r['side']} | {r['cpu']:.1f} ({r['sys']:.1f}) | {r['rss_mb']:.0f} | {r['bends_ok']} | {err} "
              f"| {100 * r['centre_rms']:.4f} | {ends} ({true_ends}) |")
    for side in sorted({r["side"] for r in rows}):
        pts = sorted((r["n"], r["cpu"], r["rss_mb"]) for r in rows if r["side"] == side)
        for (n0, t0, m0), (n1, t1, m1) in itertools.pairwise(pts):
            print(f"{side}: from {n0:,} to {n1:,} points, growth exponent of CPU {np.log(t1 / t0) / np.log(n1 / n0):.2f}, "
                  f"of peak RSS {np.log(m1 / m0) / np.log(n1 / n0):.2f}")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--single")
    ap.add_argument("--make", nargs=2)
    ap.add_argument("--tubes", type=int)
    ap.add_argument("--seed0", type=int, default=1000, help="seed of the first random tube")
    ap.add_argument("--no-large", action="store_true", help="skip the 100k / 1M point runs")
    ap.add_argument("--families", type=int, help="only the hard scenario families, this many tubes each")
    ap.add_argument("--radius-models", default="auto",
                    help="comma-separated bend radius models for the families (auto, per_bend, common)")
    ap.add_argument("--before-after", type=int, metavar="N",
                    help="every family, N tubes each, with the solver of --ref and this tree's (same samples)")
    ap.add_argument("--ref", default="main", help="git revision of the 'before' solver (default main)")
    ap.add_argument("--random-tubes", type=int, help="--before-after: this many random tubes (default: N)")
    ap.add_argument("--repeat", type=int, default=1, help="--before-after: solve every case this many times a side "
                    "(the least CPU time is kept)")
    ap.add_argument("--lm-trace", metavar="CASE", help="every least-squares round of one --before-after case "
                    "(small_bends-010): evaluations used, why it stopped, how much its cost still moved")
    ap.add_argument("--solve-cases", help=argparse.SUPPRESS)
    ap.add_argument("--scale", help="comma-separated point counts (1e6,3e6,1e7): large scans, --ref's solver and "
                    "this tree's")
    ap.add_argument("--ref-max", type=float, default=3e6, help="largest scan --scale gives the --ref solver")
    ap.add_argument("--heap", action="store_true", help="--scale: this tree's solver also with glibc's freed memory "
                    "kept in its heap (MALLOC_MMAP_THRESHOLD_, MALLOC_TRIM_THRESHOLD_)")
    ap.add_argument("--scale-one", help=argparse.SUPPRESS)
    a = ap.parse_args()
    if a.scale_one:
        scale_one(a.scale_one)
        return
    if a.scale:
        scale([int(float(v)) for v in a.scale.split(",")], a.ref, int(a.ref_max), a.heap)
        return
    if a.solve_cases:
        solve_cases(a.solve_cases)
        return
    if a.lm_trace:
        lm_trace(a.lm_trace)
        return
    if a.before_after:
        before_after(a.before_after, a.ref, a.random_tubes, a.repeat)
        return
    if a.families:
        families(a.families, tuple(a.radius_models.split(",")))
        return
    if a.make:
        make_scan(int(a.make[0]), a.make[1])
        return
    if a.single:
        print(json.dumps(single(a.single)))
        return
    n_tubes = a.tubes or (12 if a.quick else 40)
    print(f"random tubes: {n_tubes} single-view scans of 6000 points")
    rows = random_tubes(n_tubes, 6000, a.seed0)
    ok = [r for r in rows if r["ok"]]
    ang = np.concatenate([r["angle_err"] for r in ok]) if ok else np.zeros(0)
    small = np.concatenate([r["small"] for r in ok]).astype(bool) if ok else np.zeros(0, bool)
    rad = np.concatenate([r["radius_err"] for r in ok]) if ok else np.zeros(0)
    times = np.array([r["time"] for r in rows])
    large = [] if a.no_large else [run_single(100_000)] + ([] if a.quick else [run_single(1_000_000)])

    def line(name, value, target, met):
        print(f"| {name:<46} | {value:>22} | {target:>14} | {'yes' if met else 'NO':>4} |")

    print()
    print(f"| {'metric':<46} | {'measured':>22} | {'target':>14} | {'met':>4} |")
    print(f"|{'-' * 48}|{'-' * 24}|{'-' * 16}|{'-' * 6}|")
    share = len(ok) / len(rows)
    line("correct bend count", f"{len(ok)}/{len(rows)} = {100 * share:.0f} %", ">= 95 %", share >= 0.95)
    seg_ok = [r for r in ok if max(r["angle_err"], default=0.0) < 2.0]
    line("correct count and every bend within 2° (segmentation)", f"{len(seg_ok)}/{len(rows)}", "-", True)
    line("bend-angle error, median (all bends)", f"{np.median(ang):.3f}°", "<= 0.2°", np.median(ang) <= 0.2)
    line("bend-angle error, p95 / max", f"{np.percentile(ang, 95):.3f}° / {ang.max():.3f}°", "-", True)
    big = ~small
    line("bend-radius error, median (bends >= 10°)", f"{100 * np.median(rad[big]):.2f} %", "<= 2 %",
         np.median(rad[big]) <= 0.02)
    line("bend-radius error, median (bends < 10°)", f"{100 * np.median(rad[small]):.1f} %" if small.any() else "n/a",
         "(unobservable)", True)
    rows = [r for r in rows if not r.get("failed")]  # below: tubes that produced a result
    crms = np.median([r["centre_rms"] for r in rows])
    z = np.concatenate([r["z"] for r in ok]) if ok else np.zeros(0)
    line("reported sigmas covering the truth (angles, radii)", f"{100 * np.mean(z <= 2):.0f} % in 2σ, "
         f"{100 * np.mean(z <= 3):.0f} % in 3σ" if len(z) else "n/a", ">= 90 % in 2σ", len(z) and np.mean(z <= 2) >= 0.9)
    line("centreline deviation rms, median over tubes", f"{100 * crms:.2f} % r", "<= 2 % r", crms <= 0.02)
    line("centreline deviation max, median over tubes", f"{100 * np.median([r['centre_max'] for r in rows]):.2f} % r",
         "-", True)
    rsig = np.median([r["resid_sigma"] for r in rows])
    line("surface residual robust std / noise σ (median)", f"{rsig:.3f} σ", "<= 1.2 σ", rsig <= 1.2)
    line("median |residual| / σ (Gaussian: 0.674)", f"{np.median([r['resid_median'] for r in rows]):.3f} σ", "-", True)
    line("pipe radius error, median", f"{100 * np.median([r['pr_err'] for r in rows]):.3f} %", "-", True)
    line("time, 6000-point scan (median / max)", f"{np.median(times):.2f} s / {times.max():.2f} s", "< 3 s",
         np.median(times) < 3)
    for L in large:
        tgt = "< 30 s, < 2 GB" if L["n"] == 100_000 else "-"
        met = (L["time"] < 30 and L["rss_mb"] < 2048) if L["n"] == 100_000 else True
        line(f"{L['n']:,} points (npy upload): time / peak RSS", f"{L['time']:.1f} s / {L['rss_mb']:.0f} MB", tgt, met)
        line(f"{L['n']:,} points: bends ok, max angle err",
             f"{L['ok']}, {L['angle_err']:.3f}°" if L["ok"] else "False", "-", L["ok"])
    print()
    for L in large:
        print(f"{L['n']:,} points stage timings (s): " + ", ".join(f"{k} {v:.2f}" for k, v in L["timings"].items()))
    print()
    families(10 if a.quick else 50)


if __name__ == "__main__":
    main()
