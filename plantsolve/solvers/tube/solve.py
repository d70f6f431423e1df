"""The whole reconstruction, stage by stage as the paper runs it, with progress reports:

local surface fits (§2, pipe radius §3.1) → MLS spine (§3) → polygonal curve (§3, §4.5) →
arc-line splines (§4, Algorithm 1) → least squares on all samples in LRA parameters (§6), with
the number of bends chosen by the data → canonical direction → outliers and residuals (§7) →
the result in LRA form (§5.3), and the inspection against a nominal LRA when one is given.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import cKDTree

from plantsolve.schemas.common import Diagnostic, Report
from plantsolve.schemas.tube import (BendRadiusModel, Outliers, Residuals, Segment, SegmentQuality, TubeOptions,
                                     TubeRequest, TubeResult)
from plantsolve.solvers.base import Progress, Solved, SolverError, no_progress
from plantsolve.solvers.stages import Stages
from plantsolve.solvers.tube import arcline, curve, fit, local_fit, prune, sample_order, spine
from plantsolve.solvers.tube.model import (TubeModel, build_spine, control_polygon, frame_quaternion, reverse_model,
                                          with_radii)
from plantsolve.solvers.tube.determined import gap_fields, mark_rows, report_scan_gaps, scan_gaps
from plantsolve.solvers.tube.given_pipe_radius import given_radius_warning, with_given_radius_hint
from plantsolve.solvers.tube.inspection import inspect_request, options_without_nominal, withdraw_verdicts
from plantsolve.solvers.tube.inspection_report import report_inspection
from plantsolve.solvers.tube.nominal_files import resolve_nominal
from plantsolve.solvers.tube.lra import model_rows
from plantsolve.solvers.tube.bend_count import off_windows, report_bend_count, weak_bends
from plantsolve.solvers.tube.scan import TubeScan
from plantsolve.solvers.tube.validation import (
    assumed_unit_small_radius,
    implausible_against_scan,
    implausible_extent,
    scan_extent,
)

WORK_MAX = 30_000  # samples used for the local stages (1–3)
LM_SUBSAMPLE = 20_000  # early least-squares rounds
ALL_SAMPLES_AT_ONCE = 50_000  # above: the end lengths and margins of a fit re-assign the samples at the ends only
SIMPLIFY_FRACTION = 0.25  # polygon simplification tolerance as a fraction of ε (§4.5)
PRUNE_SUBSAMPLE = 3_000  # candidate refits when choosing the number of bends


def _subsample(n: int, m: int, rng: np.random.Generator) -> np.ndarray:
    return np.arange(n) if n <= m else np.sort(rng.choice(n, m, replace=False))


@dataclass
class LocalFits:
    """Stage 1: the working samples, the probes and their local surface fits."""

    work: np.ndarray
    tree: cKDTree
    probes: np.ndarray
    probe_idx: np.ndarray
    fits: local_fit.LocalFits
    labels: np.ndarray  # 0 reliable, 1 few neighbours, 2 curvature, 3 fit residual (§7)
    pipe_radius: float
    sigma_surface: float


@dataclass
class SpineSamples:
    """Stage 2: seeds projected onto the spine."""

    result: spine.SpineCloud
    seed_idx: np.ndarray
    pipe_radius: float


@dataclass
class PolygonalCurve:
    """Stage 3: the spine as a polyline, its noise, the tolerance ε and the simplified polygon."""

    poly: np.ndarray
    method: str
    sigma_spine: float
    eps: float
    simplified: np.ndarray
    shortcuts: curve.Shortcuts  # the polygon's shortcut distances, shared by its simplifications


@dataclass
class LeastSquaresFit:
    """Stage 5: the fitted model with its residuals on every sample."""

    model: TubeModel
    eps_used: float
    info: dict
    threshold: float
    inlier: np.ndarray
    residuals: np.ndarray
    segment: np.ndarray
    changes: list = field(default_factory=list)
    radius_model: BendRadiusModel | None = None


def within(res: np.ndarray, thr: float, block: int = 65_536) -> np.ndarray:
    """``np.abs(res) <= thr`` a block of samples at a time: no |res| temporary the size of a large scan (its pages
    are faulted in and zeroed for one comparison), and each block's stays in the processor's cache."""
    out = np.empty(len(res), bool)
    buf = np.empty(min(block, len(res)))
    for a in range(0, len(res), block):
        part = buf[:len(res[a:a + block])]
        np.abs(res[a:a + block], out=part)
        np.less_equal(part, thr, out=out[a:a + block])
    return out


def no_progress_tick(message: str | None = None) -> None:
    """A tick that reports nothing (stage functions called on their own)."""


def local_surface_fits(pts: np.ndarray, opts: TubeOptions, rng: np.random.Generator, tick=no_progress_tick) -> LocalFits:
    """§2 (2.1 local polynomial surface approximation, 2.2 shape operator) on a working subset,
    the pipe radius from the curvatures (§3.1), and the §7 flags of unreliable fits."""
    N = len(pts)
    scale0 = scan_extent(pts)
    work_idx = rng.permutation(N)[:WORK_MAX].copy()  # (not a view that keeps a permutation of every sample)
    work = pts[work_idx]
    tree = cKDTree(work)
    n_probe0 = min(len(work), 1500)
    probes0 = work[:n_probe0]
    f0 = local_fit.knn_fit(tree, work, probes0, 40)
    tick("local fits: pipe radius estimate")
    if not f0.ok.any():
        raise SolverError("local_fit", "no local surface fit succeeded", {"points": N})
    rp = float(opts.pipe_radius) if opts.pipe_radius else float(np.median(1.0 / np.maximum(f0.kmax[f0.ok], 1e-300)))
    if not np.isfinite(rp) or rp <= 0 or rp > scale0:
        raise SolverError("local_fit", "could not estimate a pipe radius: the samples do not look like a tube surface",
                          {"estimate": rp if np.isfinite(rp) else None})
    # thin the working set so that a 2/3 r ball holds ~60 samples (dense scans)
    cnt = np.median(tree.query_ball_point(probes0[:300], 2.0 / 3.0 * rp, return_length=True))
    if cnt > 90:
        keep = max(int(len(work) * 90 / cnt), 2000)
        work, work_idx = work[:keep], work_idx[:keep]
        tree = cKDTree(work)
    # how many probes: enough to cover the spine every r/2 many times over
    d_k, _ = tree.query(work[:300], k=min(12, len(work)))
    area_pt = np.pi * np.median(d_k[:, -1]) ** 2 / (d_k.shape[1] - 1)
    length_est = len(work) * area_pt / (1.5 * np.pi * rp)
    n_probes = int(np.clip(10 * length_est / (0.5 * rp), 1500, 5000))
    n_probes = min(n_probes, len(work))
    probes = work[:n_probes]
    probe_idx = work_idx[:n_probes]
    for _ in range(2 if not opts.pipe_radius else 1):
        # §7: a 2/3 r ball with at least 10 samples; sparse scans get a larger ball (≤ 1.1 r)
        h_fit = 2.0 / 3.0 * rp
        while h_fit < 1.1 * rp and np.median(tree.query_ball_point(probes[:200], h_fit, return_length=True)) < 14:
            h_fit *= 1.2
        fits = local_fit.fit_at(tree, work, probes, h_fit)
        tick(f"local fits at {len(probes)} probes")
        good = fits.ok & (fits.count >= 10)
        if not good.any():
            raise SolverError("local_fit", "too few neighbours for local surface fits (scan too sparse?)",
                              {"pipe_radius_estimate": rp})
        if not opts.pipe_radius:
            rp = float(np.median(1.0 / np.maximum(fits.kmax[good], 1e-300)))
    labels = local_fit.classify(fits, rp)
    sigma_surface = float(np.median(fits.sigma[labels == 0])) if (labels == 0).any() else 0.0
    return LocalFits(work, tree, probes, probe_idx, fits, labels, rp, sigma_surface)


def mls_spine(lf: LocalFits, opts: TubeOptions, tick=no_progress_tick) -> SpineSamples:
    """§3: every reliable seed projected onto the spine by a moving-least-squares cylinder fit
    (neighbourhood §3.2, tangent §3.3); the pipe radius re-estimated from the fits."""
    rp = lf.pipe_radius
    seeds_mask = lf.labels == 0
    if seeds_mask.sum() < 20:
        raise SolverError("spine", "too few reliable surface samples to project onto the spine",
                          {"reliable": int(seeds_mask.sum())})
    work2, tree2 = lf.work, lf.tree
    cnt2 = np.median(lf.tree.query_ball_point((lf.probes - rp * lf.fits.normal)[:300], 1.2 * rp, return_length=True))
    if cnt2 > 150:
        keep = max(int(len(lf.work) * 150 / cnt2), 2000)
        work2 = lf.work[:keep]
        tree2 = cKDTree(work2)
    sc = spine.mls_spine(tree2, work2, lf.probes[seeds_mask], lf.fits.normal[seeds_mask],
                         lf.fits.dir_min[seeds_mask], rp, free_radius=opts.pipe_radius is None, k=160, tick=tick)
    if sc.ok.sum() < 10:
        raise SolverError("spine", "the MLS spine projection failed for almost all samples", {})
    if opts.pipe_radius is None:
        rp = float(np.median(sc.radius[sc.ok]))
    return SpineSamples(sc, lf.probe_idx[seeds_mask], rp)


def polygonal_curve(ss: SpineSamples, opts: TubeOptions, warnings: list[Diagnostic]) -> PolygonalCurve:
    """§3 (curve reconstruction from the spine samples: thinning, NN-Crust) and §4.5
    (preprocessing: the polygon simplified within a fraction of ε before Algorithm 1)."""
    rp = ss.pipe_radius
    spine_pts = ss.result.points[ss.result.ok]
    extent = float(np.linalg.norm(spine_pts.max(0) - spine_pts.min(0)))
    spacing = max(0.5 * rp, extent / 400.0)
    thinned = curve.thin(spine_pts, spacing)
    if len(thinned) < 2:
        raise SolverError("curve", "the spine point cloud collapsed to a point", {})
    poly, poly_method = curve.reconstruct_polyline(thinned)
    if poly_method == "mst_diameter":
        warnings.append(Diagnostic(code="curve_fallback", message="NN-Crust did not give a simple path; the longest "
                                   "path of the minimum spanning tree was used instead.", details={}))
    d_sp = _dist_to_polyline(spine_pts, poly)
    sigma_spine = float(np.median(d_sp))
    eps = float(opts.tolerance) if opts.tolerance else max(0.08 * rp, 4.0 * sigma_spine)
    # a finer simplification than ε keeps the chord tangent estimates close to the curve
    # where two bends in different planes meet (§4.5 leaves the simplification tolerance open)
    shortcuts = curve.Shortcuts(poly)
    simp = curve.simplify(poly, SIMPLIFY_FRACTION * eps, shortcuts)
    return PolygonalCurve(poly, poly_method, sigma_spine, eps, simp, shortcuts)


def arcline_candidates(pc: PolygonalCurve, rp: float, opts: TubeOptions,
                       warnings: list[Diagnostic]) -> list[tuple[float, TubeModel]]:
    """§4, Algorithm 1: the G1 arc-line spline with the fewest segments within ε. Without a
    user tolerance ε is only estimated, so it runs for ε, 1.5ε and 2ε and the least-squares
    stage keeps the model with the fewest bends that fits the samples as well as the best."""
    eps, poly = pc.eps, pc.poly
    inits: list[tuple[float, TubeModel]] = []
    factors = (1.0,) if opts.tolerance else (1.0, 1.5, 2.0)
    # at ε itself the polygon simplified is the stage's own (the same call)
    simps = [pc.simplified if f == 1.0 else curve.simplify(poly, SIMPLIFY_FRACTION * eps * f, pc.shortcuts)
             for f in factors]
    # the searches of all tolerances at once (each gives what it gives alone)
    memos: list[dict] = [{} for _ in factors]  # each search's edges, for its wider search
    mdls = arcline.fit_arclines([(simp, eps * f, 0.5 * rp, 3) for simp, f in zip(simps, factors)], memos)
    dead = [k for k, mdl in enumerate(mdls) if mdl is None]
    # every kept prefix ran into a dead end: search wider before giving up ε
    for k, mdl in zip(dead, arcline.fit_arclines([(simps[k], eps * factors[k], 0.5 * rp, 8) for k in dead],
                                                 [memos[k] for k in dead])):
        mdls[k] = mdl
    for f, mdl in zip(factors, mdls):
        if mdl is not None and all(not _same_shape(mdl, m0) for _, m0 in inits):
            inits.append((eps * f, mdl))
    eps_used = eps * factors[-1]
    while not inits and eps_used < 40 * eps:
        eps_used *= 1.5
        mdl = arcline.fit_arcline(curve.simplify(poly, SIMPLIFY_FRACTION * eps_used, pc.shortcuts), eps_used,
                                   0.5 * rp)
        if mdl is not None:
            inits.append((eps_used, mdl))
            warnings.append(Diagnostic(code="tolerance_increased", message=f"No arc-line spline met ε = {eps:.4g}; "
                                       f"ε = {eps_used:.4g} was used.", details={"requested": eps, "used": eps_used}))
    if not inits:
        raise SolverError("arcline", "no arc-line spline approximates the spine within the tolerance",
                          {"tolerance": eps, "last_tried": eps_used})
    for _, mdl in inits:
        mdl.pipe_radius = rp
    return inits


def least_squares_fit(pts: np.ndarray, inits: list[tuple[float, TubeModel]], rp: float, sigma_surface: float,
                      opts: TubeOptions, rng: np.random.Generator, progress: Progress,
                      warnings: list[Diagnostic], nominal_clr: list[float] | None = None) -> LeastSquaresFit:
    """§6, least-squares distance fitting of the tube surface to the samples in LRA parameters.
    Early rounds and the choice of the number of bends (``prune``) use subsamples, the final
    round every sample; each round re-assigns samples to segments and re-fits the end straights.
    ``nominal_clr``: the CLR of each bend of the nominal, when one is given (a radius model candidate)."""
    N = len(pts)
    if opts.bend_radius:
        for _, mdl in inits:
            mdl.radii = np.full(mdl.n_bends, float(opts.bend_radius))
        mode = "fixed"
    else:
        mode = "common" if opts.common_bend_radius else "free"
    f_scale = max(2.0 * sigma_surface, 1e-3 * rp)
    margin = 2.0 * rp
    sub = _subsample(N, LM_SUBSAMPLE, rng)
    pts_sub = pts[sub]
    fit_rp = opts.pipe_radius is None

    st = Stages(progress)
    st.stage(0.55, 0.6, "least-squares fit")

    def tick():
        st.tick()  # lets a cancellation through between LM iterations

    last_assignment: list = []  # [model, residuals, segments] of every sample after a round on all of them
    last_round: list = []  # [model, samples, residuals] after the latest round, when its ends settled

    def rounds(m: TubeModel, P: np.ndarray, thr: float, n_rounds: int, max_nfev: int, radius_mode: str | None = None,
               dies: tuple[int, ...] = (), fixed_radii: tuple[float, ...] = ()):
        """Assign samples, fix end lengths, solve; repeated (the assignment changes)."""
        lay = fit.Layout(m.n_bends, radius_mode or mode, opts.bend_radius, fit_rp, dies, fixed_radii)
        info = {}
        res, seg = fit.assign(m, P, margin)
        for _ in range(n_rounds):
            inl = within(res, thr)
            res = None  # (each round assigns anew: a large scan's residuals make room for its solve)
            if inl.sum() < 10 + lay.size:
                raise SolverError("least_squares", "too few samples near the initial tube surface",
                                  {"inliers": int(inl.sum())})
            m = fit.set_end_lengths(m, P, seg, inl)
            solved, info = fit.solve_lm(m, P, seg, lay, f_scale, max_nfev=max_nfev, tick=tick, keep=inl)
            m = fit.with_end_lengths(solved, m)
            # the end straights grow by at most the margin per assignment: repeat until they
            # stop (after a bend was merged or removed the far end can be many radii off);
            # a large scan re-assigns only its samples at the ends (``fit.end_lengths``), a small one
            # keeps the inner segments' distances of this assignment for it
            res = seg = None  # (a large scan's old assignment makes room for the new one)
            if len(P) > ALL_SAMPLES_AT_ONCE:
                res, seg = fit.assign(m, P, margin)
                ends, again = fit.near_ends(m, seg), None
            else:
                res, seg, again = fit.assign_for_ends(m, P, margin)
                ends = slice(None)
            P_ends = P if isinstance(ends, slice) else np.take(P, ends, axis=0)
            m, res[ends], seg[ends], settled = fit.end_lengths(m, P_ends, res[ends], seg[ends], thr, margin,
                                                               again=again)
            del P_ends
            if P is pts:
                last_assignment[:] = [m, res, seg] if settled else []
            # the settled ends' last assignment is the returned model's (what fit.assign gives it again)
            last_round[:] = [m, P, res] if settled and len(P) <= ALL_SAMPLES_AT_ONCE else []
            # the median absolute deviation in place (a median's partition may reorder what it is taken of)
            r_in = np.compress(inl, res)
            r_in -= np.median(r_in, overwrite_input=True)
            sig = 1.4826 * float(np.median(np.abs(r_in, out=r_in), overwrite_input=True))
            del r_in
            thr = max(6.0 * sig, 0.05 * rp)
        return m, info, thr, sig

    prune_idx = _subsample(len(pts_sub), PRUNE_SUBSAMPLE, np.random.default_rng(opts.seed + 1))
    pts_prune = pts_sub[prune_idx]
    thr0 = max(0.35 * rp, 3 * max(e for e, _ in inits))

    def refit(m: TubeModel):
        m2, _, _, _ = rounds(m, pts_prune, thr0, 2, 15)
        if last_round and last_round[0] is m2 and last_round[1] is pts_prune:
            return m2, last_round[2]
        return m2, fit.assign(m2, pts_prune, margin)[0]

    assigned: dict = {}  # (id(model), id(samples)) -> (model, samples, residuals, segments)

    def assignment(m: TubeModel, P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``fit.assign(m, P, margin)``, each model's on each set of samples computed once: the bend count's
        re-check, the radius models and the final inliers all start from the fit they are given (read only)."""
        key = (id(m), id(P))
        if key not in assigned:
            assigned[key] = (m, P, *fit.assign(m, P, margin))  # (the model and samples held: their ids stay theirs)
        return assigned[key][2:]

    st.stage(0.6, 0.75, "choosing the number of bends")

    fitted = [(e,) + refit(mdl) for e, mdl in inits]
    best_i = prune.select(fitted, rp)
    eps_used, model, _ = fitted[best_i]
    changes = []
    if model.n_bends and not opts.bend_radius:
        model, _, changes = prune.prune(model, refit, eps_used, rp)
    if model.n_bends:
        model, splits = prune.split_by_evidence(model, refit, rp)
        changes = changes + splits
    st.stage(0.75, 0.8, "least-squares fit")
    model, lm_info, thr, sig = rounds(model, pts_sub, thr0, 3, 60)
    if model.n_bends > 1 and mode == "free":
        (model, lm_info, thr, sig), rechecked = prune.recheck_on_fit((model, lm_info, thr, sig), pts_sub, thr, margin,
                                                                     fit_rp, rounds, eps_used, assignment=assignment)
        changes = changes + rechecked
    radius = BendRadiusModel(chosen="fixed", criterion="options") if opts.bend_radius else None
    final_mode: dict = {}
    if model.n_bends and not opts.bend_radius:
        st.stage(0.8, 0.85, "choosing the bend radius model")
        model, lm_info, thr, radius, final_mode = choose_radius_model(model, pts_sub, thr, margin, opts, rounds,
                                                                      lm_info, nominal_clr, assignment)
        if model.n_bends > 1 and mode == "free" and final_mode.get("radius_mode") in ("common", "dies"):
            (model, lm_info, thr, final_mode), merged = prune.recheck_on_fit((model, lm_info, thr, final_mode), pts_sub,
                                                                             thr, margin, fit_rp, rounds, eps_used,
                                                                             final_mode["radius_mode"], assignment)
            if merged:
                changes = changes + merged
                # the radius models compared again for the tube with fewer bends, from its free fit
                # (started at the converged shared fit, so no radius has room to run off)
                free, lm_info, thr, _ = rounds(model, pts_sub, thr, 2, 30)
                model, lm_info, thr, radius, final_mode = choose_radius_model(free, pts_sub, thr, margin, opts,
                                                                              rounds, lm_info, nominal_clr, assignment)
    st.stage(0.85, 0.97, "final least-squares fit on all samples")
    if N > len(sub):
        model, lm_info, thr, sig = rounds(model, pts, thr, 1, 10, **final_mode)
    if N > ALL_SAMPLES_AT_ONCE:
        # the margin only reaches the samples at the ends: assigned once with it, then those again without
        if last_assignment and last_assignment[0] is model:
            _, res_all, seg_all = last_assignment
        else:
            res_all, seg_all = fit.assign(model, pts, margin)
        inlier = within(res_all, thr)
        ends = fit.near_ends(model, seg_all)
        res_all[ends], seg_all[ends] = fit.assign(model, np.take(pts, ends, axis=0), 0.0)
    else:
        # (a subsample of every sample is all of them, in their order)
        inlier = np.abs(assignment(model, pts if N > len(sub) else pts_sub)[0]) <= thr
        # final extents without the margin
        res_all, seg_all = fit.assign(model, pts, 0.0)
    last_rel = lm_info.get("last_relative_decrease")
    if lm_info.get("status", 0) == 0 and (last_rel is None or last_rel > 1e-5):
        warnings.append(Diagnostic(code="not_converged", message="The least-squares fit stopped at its evaluation "
                                   "limit; the result is the best found.", details=lm_info))
    return LeastSquaresFit(model, eps_used, lm_info, thr, inlier, res_all, seg_all, changes, radius)


def _two_dies(radii: np.ndarray, weight: np.ndarray) -> tuple[int, ...]:
    """The split of the bends' radii into two groups (in log radius) with the least within-group spread,
    each bend weighted by the information the samples hold on its radius (1 / sigma^2), so that a bend
    whose radius they do not determine neither forms a die of its own nor moves one."""
    order = np.argsort(radii)
    logr, w = np.log(radii[order]), weight[order]
    best, cut = np.inf, 1
    for k in range(1, len(logr)):
        cost = sum(float(np.sum(wg * (lg - np.average(lg, weights=wg)) ** 2))
                   for lg, wg in ((logr[:k], w[:k]), (logr[k:], w[k:])))
        if cost < best:
            best, cut = cost, k
    dies = np.zeros(len(radii), dtype=int)
    dies[order[cut:]] = 1
    return tuple(int(d) for d in dies)


def _common_starts(model: TubeModel, weight: np.ndarray) -> list[float]:
    """Start values of one shared radius: the weighted one (``_shared_radius``), and the median radius of the
    bends of 20 degrees or more when it differs by over 5 %. The sigmas of bends of a few degrees can be as
    spurious as their radii (a sharp side minimum): three such bends can pull the weighted start twice the
    die off, and the shared fit stops in a minimum far above the per-bend one."""
    starts = [_shared_radius(model.radii, weight)]
    big = model.angles >= np.radians(20.0)
    if big.any():
        r_big = float(np.median(model.radii[big]))
        if abs(np.log(r_big / starts[0])) > 0.05:
            starts.append(r_big)
    return starts


def _shared_radius(radii: np.ndarray, weight: np.ndarray) -> float:
    """Start value of a radius shared by bends: their free radii averaged with weights 1 / sigma^2. A bend
    of a few degrees wanders to any radius in a free fit (often a bound); an unweighted median or mean
    of such radii starts the shared fit far off, and it can stop in a local minimum there."""
    return float(np.exp(np.average(np.log(radii), weights=weight)))


def _nominal_per_bend(model: TubeModel, weight: np.ndarray, nominal_clr: list[float]) -> tuple[list[float], np.ndarray]:
    """The nominal's distinct CLRs, and the CLR of each bend of ``model`` (see :func:`nominal_dies`)."""
    clr = np.asarray(nominal_clr, float)
    distinct: list[float] = []
    for c in clr:
        if all(abs(c - d) > 1e-9 * max(c, d) for d in distinct):
            distinct.append(float(c))
    logr = np.log(model.radii)
    if len(clr) == model.n_bends:
        per_bend = min((clr, clr[::-1]), key=lambda c: float(np.sum(weight * (logr - np.log(c)) ** 2)))
    else:
        per_bend = np.array([distinct[int(np.argmin(np.abs(np.log(distinct) - r)))] for r in logr])
    return distinct, per_bend


# The nominal's CLRs start dies only where they can be the dies this tube was bent on: springback and die wear
# put a bend's radius within a few per cent of its die's, so CLRs this far from the scan's radii (weighted by
# what the samples hold on each) are a nominal in another unit or of another part, and dies started there
# would pull the measured radii (and the lengths beside them) towards a wrong number.
NOMINAL_CLR_RATIO = 1.5


def nominal_clr_mismatch(model: TubeModel, weight: np.ndarray, nominal_clr: list[float]) -> str | None:
    """Why the nominal's CLRs cannot be this tube's dies (a CLR not above the tube's radius, or the CLRs off the
    scan's free radii by more than :data:`NOMINAL_CLR_RATIO`), or None when they can."""
    small = [c for c in nominal_clr if c <= model.pipe_radius]
    if small:
        return (f"CLR {', '.join(f'{c:g}' for c in small[:5])} is not above the tube's radius "
                f"({model.pipe_radius:.4g})")
    _, per_bend = _nominal_per_bend(model, weight, nominal_clr)
    ratio = float(np.exp(np.average(np.log(per_bend / model.radii), weights=weight)))
    if not 1 / NOMINAL_CLR_RATIO <= ratio <= NOMINAL_CLR_RATIO:
        return f"the CLRs are {ratio:.3g} times the scan's bend radii (weighted mean)"
    return None


def nominal_dies(model: TubeModel, weight: np.ndarray, nominal_clr: list[float]) -> tuple[list[float], tuple[int, ...]]:
    """The nominal's distinct CLRs that bends of ``model`` sit on, and each bend's die (an index into them). With
    the nominal's bend count, bend i is nominal bend i in the walking direction whose CLRs lie nearer the free
    radii (in log radius, weighted by what the samples hold on each); otherwise each bend takes the CLR nearest
    its free radius."""
    distinct, per_bend = _nominal_per_bend(model, weight, nominal_clr)
    die = [int(np.argmin([abs(c - d) for d in distinct])) for c in per_bend]
    used = sorted(set(die))  # dies no bend sits on are left out: their radius would be free of any sample
    return [distinct[k] for k in used], tuple(used.index(k) for k in die)


def choose_radius_model(model: TubeModel, P: np.ndarray, thr: float, margin: float, opts: TubeOptions, rounds,
                        lm_info: dict, nominal_clr: list[float] | None = None, assignment=None):
    """Bend radius models compared on the same samples: one die for all bends ('common'), two dies with the
    bends assigned by their free radii ('dies', three bends or more), with a nominal one die per CLR it names
    started at those CLRs and each bend on its nominal bend's die ('nominal_dies'; with the scan's bend count it
    replaces 'common' and 'dies', whose groupings the nominal's tooling contradicts), a radius per bend
    ('per_bend', the model fitted so far). Each is refitted in LRA parameters, the shared radii starting from
    the free ones weighted by the information the samples hold on each (``_shared_radius``); the one with the
    smallest BIC (n ln(RSS/n) + p ln n over the samples within the threshold of the per-bend fit) is kept, unless
    the options force one. Radius is weakly observable on short arcs, so a shared radius is both what the
    bender did and what the data support; the nominal's CLRs are the dies the bender was meant to use, a start
    the free radii of small bends do not give. Returns the model, its fit info, the threshold, the report and
    the mode for the final fit on all samples. ``assignment(m, P)``: ``fit.assign(m, P, margin)`` (the caller's,
    which may have it at hand)."""
    if assignment is None:
        def assignment(m: TubeModel, P: np.ndarray):
            return fit.assign(m, P, margin)
    n = model.n_bends
    forced = "common" if opts.common_bend_radius else opts.bend_radius_model
    if opts.dies:
        die_r = np.asarray(opts.dies, dtype=float)
        assign = tuple(int(np.argmin(np.abs(die_r - r))) for r in model.radii)
        fixed = tuple(float(die_r[a]) for a in assign)
        m = model.copy()
        m.radii = np.array(fixed)
        m, info, thr2, _ = rounds(m, P, thr, 2, 30, "fixed", (), fixed)
        return m, info, thr2, BendRadiusModel(chosen="given_dies", criterion="options", die_radii=die_r.tolist(),
                                              assignment=list(assign)), {"radius_mode": "fixed", "fixed_radii": fixed}
    candidates = {"per_bend": (model, lm_info, thr, {"radius_mode": "free"})}
    res_free, seg_free = assignment(model, P)
    assigned = {id(model): (model, res_free)}  # each candidate's residuals, computed once

    def residuals(m: TubeModel) -> np.ndarray:
        if id(m) not in assigned:
            assigned[id(m)] = (m, assignment(m, P)[0])
        return assigned[id(m)][1]

    keep = np.abs(res_free) <= thr
    free_layout = fit.Layout(n, "free", None, opts.pipe_radius is None)
    sd_free = fit.parameter_sigmas(model, P[keep], seg_free[keep], free_layout)["radii"]
    weight = 1.0 / np.maximum(sd_free / model.radii, 1e-9) ** 2
    # a radius below the pipe radius is the folded inner wall's spurious minimum (see add_sigmas): its sharp
    # sigma says nothing about the die, and as a start it would drag the shared radius down to it
    weight[model.radii < model.pipe_radius] = 1e-12 * weight.max()
    # a nominal of the scan's bend count names each bend's die: a candidate sharing one radius across bends the
    # nominal puts on different dies (or splitting one of its dies in two) contradicts the tooling, and its
    # fewer parameters can win the BIC while the radii it gives are several sigma off (one radius for CLRs of
    # 22.5 to 32.6); its dies are the 'nominal_dies' candidate instead
    unused = nominal_clr_mismatch(model, weight, nominal_clr) if nominal_clr else None
    if unused:
        nominal_clr = None
    by_nominal = forced == "auto" and nominal_clr is not None and len(nominal_clr) == n
    if forced == "common" or (forced == "auto" and not by_nominal):
        best = None
        for r0 in _common_starts(model, weight):
            m, info, t2, _ = rounds(with_radii(model, np.full(n, r0)), P, thr, 2, 30, "common")
            r = residuals(m)[keep]
            if best is None or float(r @ r) < best[0]:
                best = (float(r @ r), (m, info, t2, {"radius_mode": "common"}))
        candidates["common"] = best[1]
    dies = _two_dies(model.radii, weight) if n >= 3 else ()
    if (forced == "dies" or (forced == "auto" and not by_nominal)) and dies and len(set(dies)) == 2:
        die_arr = np.asarray(dies)
        m = with_radii(model, [_shared_radius(model.radii[die_arr == d], weight[die_arr == d]) for d in dies])
        m, info, t2, _ = rounds(m, P, thr, 2, 30, "dies", dies)
        candidates["dies"] = (m, info, t2, {"radius_mode": "dies", "dies": dies})
    nominal_radii, nominal_assignment = nominal_dies(model, weight, nominal_clr) if nominal_clr else ([], ())
    if forced == "auto" and nominal_radii:
        mode = ({"radius_mode": "dies", "dies": nominal_assignment} if len(nominal_radii) > 1
                else {"radius_mode": "common"})
        m, info, t2, _ = rounds(with_radii(model, [nominal_radii[d] for d in nominal_assignment]), P, thr, 2, 30,
                                **mode)
        candidates["nominal_dies"] = (m, info, t2, mode)
    N = int(keep.sum())
    size = {"per_bend": n, "common": 1, "dies": 2, "nominal_dies": len(nominal_radii)}
    rss, bic, n_par = {}, {}, {}
    for name, (m, _, _, _) in candidates.items():
        r = residuals(m)[keep]
        rss[name] = float(np.sum(r * r))
        n_par[name] = 6 + 2 * max(n - 1, 0) + n + size[name] + int(opts.pipe_radius is None)
        bic[name] = float(N * np.log(max(rss[name], 1e-300) / N) + n_par[name] * np.log(N))
    if forced != "auto" and forced in candidates:
        chosen, how = forced, "options"
    else:
        chosen = min(bic, key=lambda k: (bic[k], size[k]))
        how = "BIC"
        if "nominal_dies" in bic and bic["nominal_dies"] - bic[chosen] < NOMINAL_PREFERRED_BIC:
            chosen = "nominal_dies"
    m, info, t2, mode = candidates[chosen]
    die_radii = assignment = None
    if chosen == "dies":
        die_radii, assignment = [float(m.radii[list(dies).index(k)]) for k in (0, 1)], list(dies)
    elif chosen == "nominal_dies":
        assignment = list(nominal_assignment)
        die_radii = [float(m.radii[assignment.index(k)]) for k in range(len(nominal_radii))]
    report = BendRadiusModel(chosen=chosen, criterion=how, values=bic, rss=rss, n_parameters=n_par,
                             die_radii=die_radii, assignment=assignment, nominal_clrs=nominal_radii or None,
                             summary=_radius_summary(chosen, how, bic, nominal_radii, unused))
    return m, info, t2, report, mode


TIED_BIC = 0.05  # BIC differences below this are one fit reached from two starts
# the nominal's dies are kept unless another model beats them by this much: a BIC difference under 2 is no
# evidence worth more than a bare mention (Kass and Raftery), and the tooling is what the bender used
NOMINAL_PREFERRED_BIC = 2.0


def _radius_summary(chosen: str, how: str, bic: dict[str, float], nominal_radii: list[float],
                    nominal_unused: str | None = None) -> str:
    """Which radius model won, in words: by the options, or by how much BIC over the runner-up."""
    unused = f"; the nominal's CLRs not used as dies: {nominal_unused}" if nominal_unused else ""
    if how != "BIC":
        return f"'{chosen}' as the options ask{unused}"

    def versus(other: str) -> str:
        gap = bic[other] - bic[chosen]
        if abs(gap) < TIED_BIC:
            return f"tied with '{other}' (the same fit)"
        if gap < 0:  # the nominal's dies kept within NOMINAL_PREFERRED_BIC
            return (f"though '{other}' scores {-gap:.1f} less (under {NOMINAL_PREFERRED_BIC:g}: no evidence against "
                    "the nominal's tooling)")
        return f"over '{other}' by {gap:.1f}"

    others = sorted((v, k) for k, v in bic.items() if k != chosen)  # the runner-up first
    text = f"BIC chose '{chosen}'" + (f" {versus(others[0][1])}" if others else "")
    if nominal_radii:
        clrs = ", ".join(f"{c:.4g}" for c in nominal_radii)
        gap = bic.get("nominal_dies", bic[chosen]) - bic[chosen]
        outcome = ("won" if chosen == "nominal_dies" else "the same fit" if gap < TIED_BIC
                   else f"{gap:.1f} worse")
        text += f"; the nominal's CLRs ({clrs}) as dies ('nominal_dies'): {outcome}"
    return text + unused


def canonical_direction(ls: LeastSquaresFit, pts: np.ndarray) -> None:
    """Start at the end with the longer straight (ties: the larger first bend), so that the
    same tube gives the same LRA whichever way the scan was walked."""
    rev = reverse_model(ls.model)
    if _prefer(rev, ls.model, ls.eps_used):
        if len(pts) > ALL_SAMPLES_AT_ONCE:
            # the same segments walked the other way: the distances stay, the segment numbers turn round
            ls.segment = 2 * ls.model.n_bends - ls.segment
        else:
            ls.residuals, ls.segment = fit.assign(rev, pts, 0.0)
        ls.model = rev


def outlier_report(ls: LeastSquaresFit, lf: LocalFits, ss: SpineSamples, order: np.ndarray) -> Outliers:
    """§7: every sample left out of the final fit, in input order, with the stage that flagged
    it (local fit, spine projection) or ``residual``."""
    out_sorted = np.flatnonzero(~ls.inlier)
    # the reasons of the left-out samples only (a label per sample of a large scan is an array of its size)
    reasons = np.array(["residual", "local_fit", "spine_projection"])
    code = np.zeros(len(out_sorted), np.int8)
    code[np.isin(out_sorted, lf.probe_idx[lf.labels != 0])] = 1
    code[np.isin(out_sorted, ss.seed_idx[~ss.result.ok])] = 2  # a later stage's flag is the one given
    out_orig = order[out_sorted]
    srt = np.argsort(out_orig)
    out_idx = out_orig[srt]
    out_reason = reasons[code[srt]]
    by_reason: dict[str, int] = {}
    for r in out_reason:
        by_reason[r] = by_reason.get(r, 0) + 1
    return Outliers(count=int(len(out_idx)), indices=[int(i) for i in out_idx],
                    reasons=[str(r) for r in out_reason], by_reason=by_reason)


def residual_summary(ls: LeastSquaresFit) -> tuple[Residuals, list[SegmentQuality]]:
    """Distances of the inliers to the fitted surface, overall and per segment."""
    absr = np.compress(ls.inlier, ls.residuals)
    np.abs(absr, out=absr)
    # one scratch array for the squares and the partitions of the median and percentiles (the numbers of
    # np.median(absr), np.mean(absr ** 2) …, which each took a fresh copy of a large scan's inliers)
    scratch = np.empty_like(absr)

    def stats(a: np.ndarray) -> dict[str, float]:
        work = scratch[:len(a)]
        rms = float(np.sqrt(np.mean(np.square(a, out=work))))
        np.copyto(work, a)
        median = float(np.median(work, overwrite_input=True))
        return {"median": median, "rms": rms, "max": float(a.max())}

    overall = stats(absr)
    np.copyto(scratch, absr)
    residuals = Residuals(count=len(absr), median=overall["median"],
                          p95=float(np.percentile(scratch, 95, overwrite_input=True)), max=overall["max"],
                          rms=overall["rms"])
    sp = build_spine(ls.model)
    # each segment's inliers picked from the inliers' distances (in sample order, as from all samples): a pass over
    # the inliers per segment, not three over every sample
    seg_in = np.compress(ls.inlier, ls.segment)
    m = np.empty(len(seg_in), bool)
    quality = []
    for k in range(len(sp.kind)):
        a = np.compress(np.equal(seg_in, k, out=m), absr)
        quality.append(SegmentQuality(index=k, type="arc" if sp.kind[k] else "line", count=len(a),
                                      **(stats(a) if len(a) else {"median": 0.0, "rms": 0.0, "max": 0.0})))
    return residuals, quality


def solve(scan: TubeScan | TubeRequest, progress: Progress = no_progress) -> Solved:
    """The reconstruction of a checked scan (``check_input``); a plain request is wrapped, for library use."""
    if isinstance(scan, TubeRequest):
        scan = TubeScan(scan)
    t_start = time.perf_counter()
    timings: dict[str, float] = {}
    request = scan.request
    # what the upload's reader left out or assumed comes first: a job fed a damaged file never looks clean
    warnings: list[Diagnostic] = [Diagnostic(**w.model_dump()) for w in request.source.warnings] if request.source else []
    if request.options.file_units and request.source is None:
        warnings.append(Diagnostic(code="file_units_ignored", message="options.file_units applies to uploaded point "
                                   f"files only: the points of a JSON request are in its units ({request.units}).",
                                   details={"file_units": request.options.file_units, "units": request.units}))
    opts = request.options
    if (ignored := options_without_nominal(opts)) is not None:
        warnings.append(ignored)
    pts_in = scan.points
    rng = np.random.default_rng(opts.seed)
    # canonical order: the result must not depend on the order of the input samples
    order = sample_order.lexicographic(pts_in)
    pts = np.take(pts_in, order, axis=0)  # (the same rows as pts_in[order] in under half the time on large scans)
    N = len(pts)

    st = Stages(progress)
    st.stage(0.02, 0.12, "local polynomial fits")
    t0 = time.perf_counter()
    try:
        lf = local_surface_fits(pts, opts, rng, st.tick)
    except SolverError as exc:
        raise with_unit_hint(exc, pts, request) from None
    timings["local_fit"] = time.perf_counter() - t0

    nominal = resolve_nominal(opts, request.units)
    nominal_clr = [r.bend_radius for r in nominal.rows[:-1]] if nominal is not None and not opts.bend_radius else None
    try:  # a given pipe radius is held in every stage below: when one fails, the radius is the likely cause
        st.stage(0.12, 0.3, "MLS spine projection")
        t0 = time.perf_counter()
        ss = mls_spine(lf, opts, st.tick)
        rp = ss.pipe_radius
        timings["spine"] = time.perf_counter() - t0

        st.stage(0.3, 0.42, "curve reconstruction")
        t0 = time.perf_counter()
        pc = polygonal_curve(ss, opts, warnings)
        timings["curve"] = time.perf_counter() - t0

        st.stage(0.42, 0.55, "arc-line spline")
        t0 = time.perf_counter()
        inits = arcline_candidates(pc, rp, opts, warnings)
        n_bends_initial = [mdl.n_bends for _, mdl in inits]
        timings["arcline"] = time.perf_counter() - t0

        t0 = time.perf_counter()
        ls = least_squares_fit(pts, inits, rp, lf.sigma_surface, opts, rng, progress, warnings, nominal_clr)
        timings["least_squares"] = time.perf_counter() - t0
    except SolverError as exc:
        raise with_given_radius_hint(exc, opts.pipe_radius, pts, request.units) from None
    canonical_direction(ls, pts)

    st.stage(0.97, 1.0, "report")
    outliers = outlier_report(ls, lf, ss, order)
    residuals, quality = residual_summary(ls)
    if outliers.count > 0.1 * N:
        warnings.append(Diagnostic(code="many_outliers", message=f"{outliers.count} of {N} samples were discarded as "
                                   "outliers.", details={"count": int(outliers.count)}))
    if lf.sigma_surface > 0 and residuals.median > 3 * lf.sigma_surface + 0.01 * rp:
        warnings.append(Diagnostic(code="poor_fit", message="The median residual is well above the estimated scan "
                                   "noise: the tube may not be a pure arc-line pipe surface.",
                                   details={"median": residuals.median, "noise": lf.sigma_surface}))
    timings["total"] = time.perf_counter() - t_start
    labels, fits = lf.labels, lf.fits
    details = {
        "points": N, "working_samples": int(len(lf.work)), "probes": int(len(lf.probes)),
        "pipe_radius_stage1": float(np.median(1.0 / np.maximum(fits.kmax[labels == 0], 1e-300))) if (labels == 0).any() else None,
        "noise_sigma_estimate": lf.sigma_surface, "spine_noise": pc.sigma_spine,
        "stage1_flags": {"few_neighbours": int((labels == 1).sum()), "curvature": int((labels == 2).sum()),
                         "fit_residual": int((labels == 3).sum())},
        "stage2_flags": {"projection_distance": int((~ss.result.ok).sum())},
        "polyline": {"method": pc.method, "vertices": int(len(pc.poly)), "simplified": int(len(pc.simplified))},
        "bends_initial": n_bends_initial, "pruned": ls.changes, "least_squares": ls.info, "timings_s": timings,
        "outlier_threshold": float(ls.threshold),
    }
    if request.source:
        details["source"] = request.source.model_dump()
    warnings.extend(implausible_against_scan(ls.model, opts, request.units, scan_extent(pts),
                                             request.source.units.file_unit if request.source else None))
    if (assumed := assumed_unit_small_radius(float(ls.model.pipe_radius), request)) is not None:
        warnings.append(assumed)
    if opts.pipe_radius and (off := given_radius_warning(ls.model, pts, ls.segment, ls.inlier, request.units)):
        warnings.insert(0, off)
    if ls.radius_model is not None and ls.radius_model.summary:
        details["bend_radius_model"] = ls.radius_model.summary
    report = Report(status="warning" if warnings else "ok", message=f"{ls.model.n_bends} bends reconstructed.",
                    warnings=warnings, details=details)
    result = result_from_model(ls.model, ls.eps_used, request.units, residuals, outliers, quality, report,
                               ls.radius_model)
    loose = add_sigmas(result, ls, pts, opts)
    mark_rows(result.lra, ls.model, np.compress(ls.inlier, ls.segment), loose)
    # before the inspection: the rows a systematic misfit lies on get no verdict
    report_bend_count(result, off_windows(ls.model, pts, ls.residuals, ls.segment, ls.inlier), weak_bends(result),
                      request.units)
    gaps = scan_gaps(ls.model, pts, ls.inlier)
    report_scan_gaps(result, gaps, request.units)
    result.inspection = inspect_request(ls.model, opts, request.units, result.lra)
    if result.inspection is not None and gaps:  # no verdict on what no sample shows
        two_pieces = any(g.two_pieces for g in gaps)
        withdraw_verdicts(result.inspection, None if two_pieces else gap_fields(gaps))
    if result.inspection is not None:
        report_inspection(result.report, result.inspection, request.units)
    progress(1.0, "done")
    return Solved(result)


def with_unit_hint(exc: SolverError, pts: np.ndarray, request: TubeRequest) -> SolverError:
    """A failed local fit on a scan whose size is implausible in the request's unit (a scan in metres read as
    millimetres spans a few millimetres) says so and names the likely unit: that is the likely cause."""
    extent = scan_extent(pts)
    hint = implausible_extent(extent, request.units, request.source.units.file_unit if request.source else None)
    if hint is None:
        return exc
    return SolverError(exc.stage, f"{exc.message}; {hint}", {**exc.details, "extent": extent, "units": request.units})


def add_sigmas(result: TubeResult, ls: LeastSquaresFit, pts: np.ndarray, opts: TubeOptions) -> list[int]:
    """Standard deviations of every LRA row from the Jacobian at the solution (inlier samples), and a
    warning for bends whose radius the data do not determine (sigma above 10 % of the radius, or a
    radius below the pipe radius); returns those bends (0-based)."""
    model = ls.model
    n = model.n_bends
    if n == 0:
        return []
    chosen = ls.radius_model.chosen if ls.radius_model is not None else ("common" if opts.common_bend_radius else "per_bend")
    mode = {"common": "common", "dies": "dies", "nominal_dies": "dies", "per_bend": "free"}.get(chosen, "fixed")
    die_r = sorted({float(r) for r in model.radii})
    dies = tuple(int(np.argmin([abs(r - d) for d in die_r])) for r in model.radii) if mode == "dies" else ()
    fixed = tuple(float(r) for r in model.radii) if mode == "fixed" else ()
    lay = fit.Layout(n, mode, opts.bend_radius, opts.pipe_radius is None, dies, fixed)
    sd = fit.parameter_sigmas(model, pts, ls.segment, lay, keep=ls.inlier)
    rows = result.lra
    for k, row in enumerate(rows):
        if 1 <= k <= n - 1:
            row.sigma_length = float(sd["lengths"][k - 1])
            row.sigma_rotation = float(np.degrees(sd["rotations"][k - 1]))
        elif k == 0:
            row.sigma_rotation = 0.0
        if k < n:
            row.sigma_angle = float(np.degrees(sd["angles"][k]))
            row.sigma_bend_radius = float(sd["radii"][k])
    # a radius below the pipe radius is no bend a bender makes: the tube surface there is a spindle torus,
    # whose folded inner wall gives a bend of a few degrees a sharp but spurious minimum, so its sigma
    # (often a few percent) describes that fold, not the die
    loose = {k for k in range(n) if rows[k].sigma_bend_radius > 0.1 * rows[k].bend_radius
             or rows[k].bend_radius < model.pipe_radius}
    if mode == "free":
        loose |= set(radii_fitting_as_well(model, pts, loose, keep=ls.inlier))
    loose = sorted(loose)
    if loose:
        result.report.warnings.append(Diagnostic(
            code="bend_radius_undetermined",
            message=f"The radius of bend(s) {', '.join(str(k + 1) for k in loose)} is not determined by the data "
            "(standard deviation above 10 % of the radius, a radius below the pipe radius, or half or twice the "
            "radius fitting about as well): give the die radius (options.bend_radius or dies).",
            details={"bends": [{"bend": k + 1, "bend_radius": rows[k].bend_radius,
                                "sigma_bend_radius": rows[k].sigma_bend_radius} for k in loose]}))
        result.report.status = "warning"
    return loose


def radii_fitting_as_well(model: TubeModel, pts: np.ndarray, skip=(), keep: np.ndarray | None = None) -> list[int]:
    """Bends (other than ``skip``) whose free radius the samples do not pin down beyond the point it was fitted
    at: with the radius held at half or at twice its value (within the fit's bounds) and the control polygon
    kept (``with_radii``), the sum of squared residuals rises by less than a standard deviation of 10 % of the
    radius predicts, Δχ² < ((R' - R) / 0.1 R)² (25 at half, 100 at twice), in units of the fit's residual
    variance. The sigma from the Jacobian describes the minimum the fit stopped in; for a bend of a few degrees
    that can be one of several (a radius below the pipe's, or one of 150 pipe radii with a sigma of 2 %), chosen by
    round-off, and this secant test sees the cost stay flat (or fall) across them. Without a refit the rise is
    an upper bound of the profile's, so no bend is flagged that a refit would show determined. ``keep``: the
    samples to test on (a mask; default all)."""
    n = model.n_bends
    rp = model.pipe_radius
    lo, hi = 0.5 * rp, 200.0 * rp  # the radius bounds of the fit (``fit.bounds``)
    held = []  # (bend, held radius, its model), the lower one of a bend first
    for k in range(n):
        if k in skip:
            continue
        R = float(model.radii[k])
        for R_held in (max(0.5 * R, lo), min(2.0 * R, hi)):
            if abs(R_held - R) > 1e-3 * R:
                radii = model.radii.copy()
                radii[k] = R_held
                held.append((k, R_held, with_radii(model, radii)))
    # every model's sum of squares in one pass over the samples, each block's distances to the fitted model's
    # segments shared by the held ones (a held radius moves its bend and the straights on either side)
    rss0, rss = fit.sums_of_squares(model, [m for _, _, m in held], pts, keep)
    n_samples = len(pts) if keep is None else int(np.count_nonzero(keep))
    s2 = rss0 / max(n_samples - fit.Layout(n, "free", None, True).size, 1)
    if s2 <= 0:
        return []
    out = []
    for (k, R_held, _), rss_k in zip(held, rss):
        if k not in out and (rss_k - rss0) / s2 < ((R_held - model.radii[k]) / (0.1 * model.radii[k])) ** 2:
            out.append(k)
    return out


def _same_shape(a: TubeModel, b: TubeModel) -> bool:
    return a.n_bends == b.n_bends and bool(np.all(np.abs(a.angles - b.angles) < np.radians(1.0)))


def _prefer(a: TubeModel, b: TubeModel, tol: float) -> bool:
    """True when model a (one walking direction) is the canonical one rather than b."""
    if abs(a.lengths[0] - b.lengths[0]) > tol:
        return a.lengths[0] > b.lengths[0]
    if a.n_bends and abs(a.angles[0] - b.angles[0]) > np.radians(0.5):
        return a.angles[0] > b.angles[0]
    return False


def _dist_to_polyline(p: np.ndarray, poly: np.ndarray) -> np.ndarray:
    if len(poly) < 2:
        return np.linalg.norm(p - poly[0], axis=1)
    tree = cKDTree(poly)
    _, i = tree.query(p)
    best = np.full(len(p), np.inf)
    for off in (-1, 0):
        a = np.clip(i + off, 0, len(poly) - 2)
        A, B = poly[a], poly[a + 1]
        ab = B - A
        t = np.clip(((p - A) * ab).sum(1) / np.maximum((ab * ab).sum(1), 1e-300), 0, 1)
        best = np.minimum(best, np.linalg.norm(p - A - t[:, None] * ab, axis=1))
    return best


def segments_of(model: TubeModel) -> list[Segment]:
    sp = build_spine(model)
    out = []
    ax = sp.axis
    for k in range(len(sp.kind)):
        if sp.kind[k] == 0:
            out.append(Segment(type="line", start=sp.start[k].tolist(), end=sp.end[k].tolist()))
        else:
            out.append(Segment(type="arc", start=sp.start[k].tolist(), end=sp.end[k].tolist(),
                               centre=sp.centre[k].tolist(), radius=float(sp.radius[k]),
                               angle=float(np.degrees(sp.angle[k])), normal=ax[k].tolist()))
    return out


def result_from_model(model: TubeModel, eps: float, units, residuals, outliers, quality, report,
                      radius_model: BendRadiusModel | None = None) -> TubeResult:
    cp, _ = control_polygon(model)
    if radius_model is not None and radius_model.chosen == "dies":  # after the final fit, in the result's bend order
        die_r = sorted({float(r) for r in model.radii})
        radius_model.die_radii = die_r
        radius_model.assignment = [int(np.argmin([abs(r - d) for d in die_r])) for r in model.radii]
    elif radius_model is not None and radius_model.chosen in ("given_dies", "nominal_dies"):
        die_r = radius_model.die_radii
        radius_model.assignment = [int(np.argmin([abs(r - d) for d in die_r])) for r in model.radii]
    return TubeResult(pipe_radius=float(model.pipe_radius), start=model.start.tolist(), bend_radius_model=radius_model,
                      orientation=frame_quaternion(model.frame), lra=model_rows(model),
                      control_polygon=cp.tolist(), segments=segments_of(model), residuals=residuals,
                      outliers=outliers, segment_quality=quality, tolerance=float(eps), units=units, report=report)
