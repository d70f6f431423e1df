"""The ``perfmap`` pipeline: characteristics -> error table -> envelopes -> map."""

from __future__ import annotations

import numpy as np

from schemas.common import Diagnostic, Report
from schemas.perfmap import (
    Envelope,
    ErrorTableRow,
    PerfmapRequest,
    PerfmapResult,
    PerformanceMap,
    SettingFit,
)
from solvers.base import Progress, SolverError, no_progress
from solvers.perfmap.envelopes import envelope
from solvers.perfmap.families import (
    EFFICIENCY_FAMILY,
    FAMILIES,
    N_COEFFICIENTS,
    CurveSet,
    log_params_to_public,
)
from solvers.perfmap.fitting import SettingResult, concave_floor, fit_setting
from solvers.perfmap.performance_map import binned_map, curve_ranges, exact_map, grid_axes
from solvers.perfmap.triangulation import triangulate
from solvers.perfmap.validation import Setting, prepare


def _nan_to_none(a: np.ndarray) -> list:
    return [[None if not np.isfinite(v) else float(v) for v in row] for row in np.atleast_2d(a)]


def _choose_family(fits: dict[str, list[SettingResult]]) -> tuple[str, dict]:
    """Family with the smallest leave-one-out error, pressure and efficiency weighted alike.

    Score = mean LOO pressure error / best family's + mean LOO efficiency error / best
    family's (scale-free: efficiency errors, often much larger near choke, do not swamp the
    pressure). Near-ties go to the family with fewer coefficients.
    """
    means = {}
    for fam, rs in fits.items():
        if all(r.pressure_loo is not None and r.efficiency_loo is not None for r in rs):
            means[fam] = (float(np.mean([r.pressure_loo for r in rs])),
                          float(np.mean([r.efficiency_loo for r in rs])))
    if not means:
        return "parabola", {}
    eps = 1e-9
    bp = min(v[0] for v in means.values())
    be = min(v[1] for v in means.values())
    scores = {f: (p + eps) / (bp + eps) + (e + eps) / (be + eps) for f, (p, e) in means.items()}
    best = min(scores, key=lambda f: (round(scores[f], 6), N_COEFFICIENTS[f], FAMILIES.index(f)))
    return best, {"scores": scores, "mean_loo": means}


def _public_coefficients(r: SettingResult, s: Setting) -> list[float]:
    if r.family == "log":
        return log_params_to_public(r.pressure.params, float(s.x[0]), float(s.x[-1]))
    return [float(v) for v in r.pressure.params]


def curveset_from_fits(settings: list[SettingFit]) -> CurveSet:
    return CurveSet([s.family for s in settings], [s.efficiency_family for s in settings],
                    [s.x_min for s in settings], [s.x_max for s in settings],
                    [s.pressure_coefficients for s in settings],
                    [s.efficiency_coefficients for s in settings])


def solve(request: PerfmapRequest, progress: Progress = no_progress) -> PerfmapResult:
    opts = request.options
    settings = prepare(request)
    progress(0.02, "input checked")
    warnings: list[Diagnostic] = []
    minimax = opts.fit == "minimax"

    # --- characteristics of every family (the paper's Table 1 for these data)
    fits: dict[str, list[SettingResult]] = {f: [] for f in FAMILIES}
    n_steps = len(FAMILIES) * len(settings)
    step = 0
    for fam in FAMILIES:
        for s in settings:
            fits[fam].append(fit_setting(fam, s.t, s.y, s.eta, minimax, opts.concave_efficiency))
            step += 1
            progress(0.02 + 0.58 * step / n_steps, f"fitting {fam}")
    floors = [concave_floor(s.x, s.y) for s in settings]

    table = []
    for fam in FAMILIES:
        rs = fits[fam]
        perr = [r.pressure_err for r in rs]
        ploo = [r.pressure_loo for r in rs]
        eloo = [r.efficiency_loo for r in rs]
        table.append(ErrorTableRow(
            family=fam, n_coefficients=N_COEFFICIENTS[fam],
            pressure_max_rel_error=float(max(perr)),
            efficiency_max_rel_error=(None if fam == "log"
                                      else float(max(r.efficiency_err for r in rs))),
            pressure_loo=None if any(v is None for v in ploo) else float(max(ploo)),
            efficiency_loo=None if any(v is None for v in eloo) else float(max(eloo)),
            floor=float(max(floors)), worst_setting=int(np.argmax(perr))))

    if opts.model == "auto":
        family, details = _choose_family(fits)
        details["criterion"] = ("mean LOO pressure error / best family's + mean LOO "
                                "efficiency error / best family's")
        if "scores" not in details:
            warnings.append(Diagnostic(code="auto_without_loo", message="Too few points per "
                            "setting for leave-one-out errors; 'auto' fell back to 'parabola'."))
    else:
        family, details = opts.model, {}

    chosen = fits[family]
    out_settings = []
    for k, (s, r) in enumerate(zip(settings, chosen)):
        out_settings.append(SettingFit(
            theta=s.theta, phi=s.phi, family=family, efficiency_family=EFFICIENCY_FAMILY[family],
            x_min=float(s.x[0]), x_max=float(s.x[-1]),
            pressure_coefficients=_public_coefficients(r, s),
            efficiency_coefficients=[float(v) for v in r.efficiency.params],
            n_points=len(s.x), pressure_max_rel_error=r.pressure_err,
            efficiency_max_rel_error=r.efficiency_err, pressure_loo=r.pressure_loo,
            efficiency_loo=r.efficiency_loo, floor=floors[k],
            active_side_conditions=r.pressure.active))
        where = {"setting": k, "position": s.source_index, "theta": s.theta, "phi": s.phi}
        if floors[k] > 0:
            warnings.append(Diagnostic(
                code="data_not_decreasing_concave",
                message=f"Setting theta={s.theta:g}, phi={s.phi:g}: the measured pressures are "
                f"not decreasing and concave; no admissible curve can beat a max relative "
                f"error of {100 * floors[k]:.2f}% (the floor), the {family} fit reaches "
                f"{100 * r.pressure_err:.2f}%.",
                details={**where, "floor": floors[k], "fit_error": r.pressure_err}))
        if len(s.x) < N_COEFFICIENTS[family]:
            warnings.append(Diagnostic(
                code="underdetermined_fit",
                message=f"Setting theta={s.theta:g}, phi={s.phi:g} has {len(s.x)} points for "
                f"{N_COEFFICIENTS[family]} coefficients: the fit is not unique.",
                details=where))
        if s.merged_duplicates:
            warnings.append(Diagnostic(
                code="duplicate_points_merged",
                message=f"Setting theta={s.theta:g}, phi={s.phi:g}: {s.merged_duplicates} "
                "repeated measurement(s) merged.", details=where))

    curves = curveset_from_fits(out_settings)
    theta = np.array([s.theta for s in settings])
    phi = np.array([s.phi for s in settings])

    # --- envelopes per theta
    envs = []
    for th in sorted(set(theta.tolist())):
        members = [i for i in range(len(settings)) if theta[i] == th]
        e = envelope(curves, members, phi, opts.envelope_curves, opts.envelope_points)
        envs.append(Envelope(theta=th, flow=e["flow"].tolist(),
                             pressure=_nan_to_none(e["pressure"])[0],
                             phi=_nan_to_none(e["phi"])[0],
                             efficiency=_nan_to_none(e["efficiency"])[0]))
    progress(0.62, "envelopes")

    ranges = curve_ranges(curves)
    triangles = np.zeros((0, 3), dtype=int)
    pmap = None
    if opts.map:
        triangles = triangulate(theta, phi)
        if len(triangles) == 0:
            raise SolverError("triangulation", "no non-degenerate triangle of settings",
                              {"n_settings": len(settings)})
        gx, gy = grid_axes(ranges, *opts.grid)
        if opts.map_method == "exact":
            t = np.linspace(0.0, 1.0, opts.t_samples)
            eta, th_map, ph_map = exact_map(curves, triangles, theta, phi, t, gx, gy, ranges,
                                            progress, 0.62, 0.98)
        else:
            eta, th_map, ph_map = binned_map(curves, triangles, theta, phi, gx, gy, ranges,
                                             m_t=opts.t_samples - 1)
        pmap = PerformanceMap(method=opts.map_method, flow=gx.tolist(), pressure=gy.tolist(),
                              efficiency=_nan_to_none(eta), theta=_nan_to_none(th_map),
                              phi=_nan_to_none(ph_map), t_samples=opts.t_samples,
                              reachable_fraction=float(np.mean(np.isfinite(eta))))
    else:
        warnings.append(Diagnostic(code="map_skipped", message="options.map is false: no "
                                   "performance map and no inverse query for this job."))
    progress(1.0, "done")

    report = Report(status="warning" if warnings else "ok",
                    message=f"{len(settings)} settings fitted with family '{family}' "
                    f"({opts.fit}); {len(envs)} envelope(s)"
                    + (f"; map {opts.grid[0]}x{opts.grid[1]} over {len(triangles)} triangles"
                       if pmap else ""),
                    warnings=warnings, details={"family_choice": details})
    return PerfmapResult(report=report, family=family, fit=opts.fit, settings=out_settings,
                         error_table=table, envelopes=envs, triangles=triangles.tolist(),
                         map=pmap, flow_range=[ranges[0], ranges[1]],
                         pressure_range=[ranges[2], ranges[3]])
