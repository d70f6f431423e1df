"""The ``perfmap`` solve, stage by stage as the paper's HV-Turbo chapter runs:

characteristics of every family (§2, with the paper's Table 1 for the submitted data) →
choice of family → per-setting results and their diagnostics → envelopes per θ (§3) →
the maximum-efficiency map over triangles of settings (§4).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from plantsolve.schemas.common import Diagnostic, Report
from plantsolve.schemas.perfmap import (
    BetaLine,
    BetaMap,
    EfficiencyErrorRow,
    Envelope,
    ErrorTableRow,
    LimitPoint,
    PerfmapRequest,
    PerfmapResult,
    PerformanceMap,
    SettingFit,
)
from plantsolve.solvers.base import Progress, Solved, SolverError, no_progress
from plantsolve.solvers.perfmap.beta_grid import BetaGridError, tabulate
from plantsolve.solvers.perfmap.envelopes import envelope
from plantsolve.solvers.perfmap.families import (
    EFFICIENCY_FAMILY,
    FAMILIES,
    PAPER_FAMILIES,
    N_COEFFICIENTS,
    CurveSet,
    curveset_from_fits,
    log_params_to_public,
)
from plantsolve.solvers.perfmap.efficiency import EFFICIENCY_FAMILIES, N_EFF_COEFFICIENTS
from plantsolve.solvers.perfmap.gasturb_map import GSP_MAX_ARGUMENTS, GSP_MAX_PARAMETERS
from plantsolve.solvers.perfmap.fitting import (
    EtaResult,
    PressureResult,
    concave_floor,
    fit_eta_setting,
    fit_pressure_setting,
)
from plantsolve.solvers.perfmap.plausibility import exports_speed_not_relative, last_setting_not_speed
from plantsolve.solvers.perfmap.performance_map import binned_map, curve_ranges, exact_map, grid_axes
from plantsolve.solvers.perfmap.triangulation import map_simplices
from plantsolve.solvers.perfmap.validation import PerfmapInput, loaded
from plantsolve.solvers.perfmap.setting_lines import CHOKE_FLOW_TOLERANCE, Setting, map_impossible


EFFICIENCY_POOR_REL = 0.05  # efficiency_fit_poor above a 5 % max relative error
PRESSURE_EXCESS = 0.01  # pressure_fit_poor: max relative error more than 1 % above the setting's floor
EFFICIENCY_OVERSHOOT = 0.02  # efficiency_above_measured: fitted peak above the measured max


def _nan_to_none(a: np.ndarray) -> list:
    return [[None if not np.isfinite(v) else float(v) for v in row] for row in np.atleast_2d(a)]


def _choose_family(fits: dict[str, list[PressureResult]]) -> tuple[str, dict]:
    """Pressure family with the smallest mean (over settings) leave-one-out pressure error;
    near-ties go to the family with fewer coefficients. (The efficiency family is chosen
    separately, per setting: :func:`_choose_efficiency`.)"""
    means = {fam: float(np.mean([r.loo for r in rs])) for fam, rs in fits.items()
             if fam in PAPER_FAMILIES and all(r.loo is not None for r in rs)}
    if not means:
        return "parabola", {}
    best = min(means, key=lambda f: (round(means[f], 9), N_COEFFICIENTS[f], FAMILIES.index(f)))
    return best, {"mean_pressure_loo": means}


def _reach_floor(results: list[PressureResult], floor: float) -> PressureResult:
    """A setting the shared family misses by more than PRESSURE_EXCESS above its floor gets the fit
    that reaches it: among those within it, the smallest leave-one-out error (ties: least squares
    before minimax, the paper's families before 'concave', fewer coefficients first); if none, the
    smallest error."""
    def rank(r: PressureResult) -> tuple:
        return (r.minimax, N_COEFFICIENTS[r.family] if r.family != "concave" else 99, FAMILIES.index(r.family))

    within = [r for r in results if r.err <= floor + PRESSURE_EXCESS]
    if within:
        return min(within, key=lambda r: (round(r.loo if r.loo is not None else r.err, 9),) + rank(r))
    return min(results, key=lambda r: (r.err,) + rank(r))


def _minimax_candidates(ch: Characteristics, s: Setting, k: int) -> list[PressureResult]:
    """Every family fitted to setting k by minimax, for a setting no least-squares fit brings within
    PRESSURE_EXCESS of its floor: a line that rises towards surge (the floor is then a few per cent)
    pulls a least-squares fit of few points by the square of that misfit, so its worst point ends
    well above the floor, while the minimax broken line reaches the floor exactly. Leave-one-out
    errors are the family's (least-squares refits), so the candidates rank as in :func:`_reach_floor`."""
    out = []
    for fam in FAMILIES:
        r = fit_pressure_setting(fam, s.t, s.y, True, with_loo=False)
        r.loo = ch.pressure[fam][k].loo
        r.err = _clamp_to_floor(r.err, ch.floors[k])
        out.append(r)
    return out


def _clamp_to_floor(err: float, floor: float) -> float:
    """No fit beats the floor; a minimax fit hits it up to the LP's tolerance."""
    return max(err, floor) if err > floor - 1e-7 else err


def _floor_missed_reason(opts) -> tuple[str, str]:
    """Why a setting's pressure fit ends more than PRESSURE_EXCESS above its floor (machine-readable
    code, sentence)."""
    if opts.model != "auto":
        return "model_forced", (f"options.model is {opts.model!r} for every setting (model 'auto', or "
                                "'concave' with fit 'minimax', reaches the floor)")
    # 'auto' tries the minimax broken line, which reaches the floor unless its LP fails numerically
    return "minimax_not_converged", "even the minimax broken line did not reach it (its linear programme failed)"


def _choose_efficiency(results: dict[str, EtaResult]) -> str:
    """Efficiency family of one setting with the smallest leave-one-out max absolute error
    (efficiency is a fraction: absolute errors compare across the curve, relative ones are
    inflated at choke where eta is small); near-ties go to fewer coefficients."""
    scored = {f: r.loo_abs for f, r in results.items() if r.loo_abs is not None}
    if not scored:
        return "parabola"
    return min(scored, key=lambda f: (round(scored[f], 9), N_EFF_COEFFICIENTS[f],
                                      EFFICIENCY_FAMILIES.index(f)))


def _public_coefficients(r: PressureResult, s: Setting) -> list[float]:
    if r.family == "concave":  # [flows of the knots..., pressures at them...]
        return [float(v) for v in s.x] + [float(v) for v in r.fit.params]
    if r.family == "log":
        return log_params_to_public(r.fit.params, float(s.x[0]), float(s.x[-1]))
    return [float(v) for v in r.fit.params]


def _efficiency_diagnostics(s: Setting, e: EtaResult, where: dict) -> list[Diagnostic]:
    out = []
    if e.rel_err > EFFICIENCY_POOR_REL:
        i = e.worst
        out.append(Diagnostic(
            code="efficiency_fit_poor",
            message=f"Setting {s.label}: the {e.family} efficiency fit "
            f"misses a measured point by {100 * e.rel_err:.1f}% (relative; max absolute error "
            f"{e.abs_err:.3f}), worst at flow {s.x[i]:g} where eta = {s.eta[i]:.3f}.",
            details={**where, "family": e.family, "max_rel_error": e.rel_err,
                     "max_abs_error": e.abs_err, "worst_flow": float(s.x[i]),
                     "worst_efficiency": float(s.eta[i])}))
    overshoot = e.peak - float(s.eta.max())
    if overshoot > EFFICIENCY_OVERSHOOT:
        out.append(Diagnostic(
            code="efficiency_above_measured",
            message=f"Setting {s.label}: the fitted efficiency peaks at "
            f"{e.peak:.4f}, {overshoot:.4f} above the best measured point ({s.eta.max():.4f}).",
            details={**where, "peak": e.peak, "measured_max": float(s.eta.max())}))
    return out


@dataclass
class Characteristics:
    """Every family fitted to every setting (§2): pressure fits, efficiency fits, floors."""

    pressure: dict[str, list[PressureResult]]
    efficiency: dict[str, list[EtaResult]]
    floors: list[float]


def fit_characteristics(settings: list[Setting], minimax: bool, concave_efficiency: bool,
                        progress: Progress) -> Characteristics:
    """§2 (2.1 parabolas, 2.2 logarithms, 2.3 cubic Bézier, 2.4 quadratic B-splines): each
    pressure family and each efficiency family on each setting, with the side conditions
    y' ≤ 0, y'' ≤ 0 held exactly; plus the concave floor of each setting."""
    fits: dict[str, list[PressureResult]] = {f: [] for f in FAMILIES}
    eta_fits: dict[str, list[EtaResult]] = {f: [] for f in EFFICIENCY_FAMILIES}
    n_steps = (len(FAMILIES) + len(EFFICIENCY_FAMILIES)) * len(settings)
    step = 0
    for fam in FAMILIES:
        for s in settings:
            fits[fam].append(fit_pressure_setting(fam, s.t, s.y, minimax))
            step += 1
            progress(0.02 + 0.58 * step / n_steps, f"fitting {fam}")
    for efam in EFFICIENCY_FAMILIES:
        for s in settings:
            eta_fits[efam].append(fit_eta_setting(efam, s.t, s.eta, minimax, concave_efficiency))
            step += 1
            progress(0.02 + 0.58 * step / n_steps, f"fitting efficiency {efam}")
    floors = [concave_floor(s.x, s.y) for s in settings]
    for fam in FAMILIES:
        for r, floor in zip(fits[fam], floors):
            r.err = _clamp_to_floor(r.err, floor)
    return Characteristics(fits, eta_fits, floors)


def error_table(ch: Characteristics) -> list[ErrorTableRow]:
    """The paper's Table 1 (§2) for the submitted data: per pressure family its worst relative
    errors, with the efficiency family the paper pairs it with, leave-one-out errors and the
    floor."""
    table = []
    for fam in PAPER_FAMILIES:
        rs = ch.pressure[fam]
        es = ch.efficiency[EFFICIENCY_FAMILY[fam]]  # the paper's pairing
        perr = [r.err for r in rs]
        ploo = [r.loo for r in rs]
        eloo = [r.loo_rel for r in es]
        table.append(ErrorTableRow(
            family=fam, n_coefficients=N_COEFFICIENTS[fam],
            pressure_max_rel_error=float(max(perr)),
            efficiency_max_rel_error=(None if fam == "log"
                                      else float(max(r.rel_err for r in es))),
            efficiency_max_abs_error=(None if fam == "log"
                                      else float(max(r.abs_err for r in es))),
            pressure_loo=None if any(v is None for v in ploo) else float(max(ploo)),
            efficiency_loo=None if any(v is None for v in eloo) else float(max(eloo)),
            floor=float(max(ch.floors)), worst_setting=int(np.argmax(perr))))
    return table


def choose_families(ch: Characteristics, settings: list[Setting], opts, warnings: list[Diagnostic],
                    minimax_fallback: bool = True) -> tuple[str, list[PressureResult], list[str], dict]:
    """The shared pressure family (``model``, or the paper family with the best mean leave-one-out
    error), the pressure fit of each setting ('auto': the shared family unless it misses the setting's
    floor by more than PRESSURE_EXCESS, see :func:`_reach_floor`; if no least-squares fit reaches it,
    the minimax fits compete too, see :func:`_minimax_candidates`; ``minimax_fallback=False``: least
    squares only, the rule before) and the efficiency family of each setting (``efficiency_model``)."""
    n_settings = len(settings)
    if opts.model == "auto":
        family, details = _choose_family(ch.pressure)
        details["criterion"] = ("mean over settings of the LOO max relative pressure error; a setting the "
                                f"family misses by more than {PRESSURE_EXCESS:.0%} above its floor gets one "
                                "that reaches it (by minimax where no least-squares fit does)")
        if "mean_pressure_loo" not in details:
            warnings.append(Diagnostic(code="auto_without_loo", message="Too few points per "
                            "setting for leave-one-out errors; 'auto' fell back to 'parabola'."))
        pressure_choice = []
        for k in range(n_settings):
            shared = ch.pressure[family][k]
            if shared.err <= ch.floors[k] + PRESSURE_EXCESS:
                pressure_choice.append(shared)
                continue
            candidates = [ch.pressure[f][k] for f in FAMILIES]
            least_squares_miss = min(r.err for r in candidates) > ch.floors[k] + PRESSURE_EXCESS
            if minimax_fallback and opts.fit != "minimax" and least_squares_miss:
                candidates += _minimax_candidates(ch, settings[k], k)
            pressure_choice.append(_reach_floor(candidates, ch.floors[k]))
        details["settings_with_another_family"] = sum(r.family != family for r in pressure_choice)
        details["settings_fitted_by_minimax"] = sum(r.minimax and opts.fit != "minimax" for r in pressure_choice)
    else:
        family, details = opts.model, {}
        pressure_choice = [ch.pressure[family][k] for k in range(n_settings)]

    if opts.efficiency_model == "auto":
        eta_choice = [_choose_efficiency({f: ch.efficiency[f][k] for f in EFFICIENCY_FAMILIES})
                      for k in range(n_settings)]
    elif opts.efficiency_model == "same":
        eta_choice = [EFFICIENCY_FAMILY[family]] * n_settings
    else:
        eta_choice = [opts.efficiency_model] * n_settings
    details["efficiency_criterion"] = (
        "per setting: LOO max absolute efficiency error" if opts.efficiency_model == "auto"
        else f"efficiency_model = {opts.efficiency_model!r}")
    return family, pressure_choice, eta_choice, details


def efficiency_error_table(ch: Characteristics, settings: list[Setting],
                           eta_choice: list[str]) -> list[EfficiencyErrorRow]:
    """Table 1's efficiency side for every efficiency family, and how often each was chosen."""
    eta_table = []
    for efam in EFFICIENCY_FAMILIES:
        es = ch.efficiency[efam]
        lr, la = [r.loo_rel for r in es], [r.loo_abs for r in es]
        eta_table.append(EfficiencyErrorRow(
            family=efam, n_coefficients=N_EFF_COEFFICIENTS[efam],
            max_rel_error=float(max(r.rel_err for r in es)),
            max_abs_error=float(max(r.abs_err for r in es)),
            loo_rel=None if any(v is None for v in lr) else float(max(lr)),
            loo_abs=None if any(v is None for v in la) else float(max(la)),
            max_overshoot=float(max(r.peak - float(s.eta.max()) for r, s in zip(es, settings))),
            chosen=sum(c == efam for c in eta_choice)))
    return eta_table


def setting_results(ch: Characteristics, settings: list[Setting], pressure_choice: list[PressureResult],
                    eta_choice: list[str], opts, warnings: list[Diagnostic]) -> list[SettingFit]:
    """The chosen characteristic and efficiency curve of each setting in public coefficients,
    with a diagnostic wherever the data or the fit deserve one."""
    out_settings = []
    for k, s in enumerate(settings):
        r = pressure_choice[k]
        family = r.family
        e = ch.efficiency[eta_choice[k]][k]
        floor = ch.floors[k]
        out_settings.append(SettingFit(
            setting=list(s.values), theta=s.theta, phi=s.phi, family=family, efficiency_family=e.family,
            x_min=float(s.x[0]), x_max=float(s.x[-1]),
            pressure_coefficients=_public_coefficients(r, s),
            efficiency_coefficients=[float(v) for v in e.fit.params],
            n_points=len(s.x), pressure_fit="minimax" if r.minimax else "least_squares",
            pressure_max_rel_error=r.err,
            efficiency_max_rel_error=e.rel_err, efficiency_max_abs_error=e.abs_err,
            pressure_loo=r.loo, efficiency_loo=e.loo_rel, efficiency_loo_abs=e.loo_abs,
            efficiency_peak=e.peak, efficiency_bounds_active=e.fit.active_bounds,
            floor=floor, pressure_excess=max(r.err - floor, 0.0), active_side_conditions=r.fit.active))
        where = {"setting": k, "position": s.source_index, "values": list(s.values), "theta": s.theta,
                 "phi": s.phi}
        if r.minimax and opts.fit != "minimax":
            ls = min((ch.pressure[f][k] for f in FAMILIES), key=lambda q: q.err)
            warnings.append(Diagnostic(
                code="pressure_fit_minimax",
                message=f"Setting {s.label}: no least-squares fit comes within {PRESSURE_EXCESS:.0%} of the "
                f"floor ({100 * floor:.2f}%; best: {ls.family} at {100 * ls.err:.2f}%), so this line's "
                f"{family} curve minimises the worst relative error instead ({100 * r.err:.2f}%).",
                details={**where, "family": family, "fit": "minimax", "max_rel_error": r.err, "floor": floor,
                         "least_squares_family": ls.family, "least_squares_max_rel_error": ls.err}))
        if opts.fit == "minimax" and not r.minimax:
            warnings.append(Diagnostic(
                code="pressure_fit_not_minimax",
                message=f"Setting {s.label}: options.fit is 'minimax' but the linear programme of this line's "
                f"{family} curve failed (HiGHS), so it is fitted by least squares ({100 * r.err:.2f}% at its worst "
                "point): settings[].pressure_fit says 'least_squares'.",
                details={**where, "family": family, "fit": "least_squares", "asked": "minimax",
                         "max_rel_error": r.err}))
        if r.err > floor + PRESSURE_EXCESS:
            reason, why = _floor_missed_reason(opts)
            warnings.append(Diagnostic(
                code="pressure_fit_poor",
                message=f"Setting {s.label}: the {family} pressure fit misses the data by "
                f"{100 * r.err:.2f}% at its worst point, {100 * (r.err - floor):.2f}% more than the best any "
                f"decreasing concave curve reaches ({100 * floor:.2f}%): {why}.",
                details={**where, "family": family, "fit": "minimax" if r.minimax else "least_squares",
                         "max_rel_error": r.err, "floor": floor, "excess": r.err - floor, "reason": reason}))
        if floor > 0:
            warnings.append(Diagnostic(
                code="data_not_decreasing_concave",
                message=f"Setting {s.label}: the measured pressures are "
                f"not decreasing and concave; no admissible curve can beat a max relative "
                f"error of {100 * floor:.2f}% (the floor), the {family} fit reaches "
                f"{100 * r.err:.2f}%.",
                details={**where, "floor": floor, "fit_error": r.err}))
        warnings.extend(_efficiency_diagnostics(s, e, where))
        if family != "concave" and len(s.x) < N_COEFFICIENTS[family]:
            warnings.append(Diagnostic(
                code="underdetermined_fit",
                message=f"Setting {s.label} has {len(s.x)} points for "
                f"{N_COEFFICIENTS[family]} coefficients: the fit is not unique.",
                details=where))
        if s.repeated_flows:
            warnings.append(Diagnostic(
                code="repeated_flows_averaged",
                message=f"Setting {s.label}: {s.repeated_flows} reading(s) at an already "
                "measured flow (other pressure or efficiency) averaged with it.", details=where))
        if s.choke_pressures:
            warnings.append(Diagnostic(
                code="vertical_choke_segment",
                message=f"Setting {s.label}: {len(s.choke_pressures)} points at the largest flow {s.x[-1]:g} "
                f"(within {CHOKE_FLOW_TOLERANCE:.2%} of the line's flow range: a vertical choke line): the "
                "characteristic ends at the highest "
                f"({max(s.choke_pressures):g}), the rest is its choke segment.",
                details={**where, "flow": float(s.x[-1]), "pressures": s.choke_pressures}))
        if s.merged_duplicates:
            warnings.append(Diagnostic(
                code="duplicate_points_merged",
                message=f"Setting {s.label}: {s.merged_duplicates} "
                "repeated measurement(s) merged.", details=where))
    return out_settings


def limit_lines(curves: CurveSet, settings: list[Setting], margin: float):
    """Surge and choke lines (the two ends of every characteristic) and, with a margin, the point of each
    characteristic whose pressure is p_surge / (1 + margin) (bisection in t: pressure decreases along it)."""
    n = curves.n
    idx = np.arange(n)
    x0, y0, e0 = curves.evaluate(idx, np.zeros(n))
    x1, y1, e1 = curves.evaluate(idx, np.ones(n))
    surge = [LimitPoint(setting=list(s.values), theta=s.theta, phi=s.phi, flow=float(x0[k]), pressure=float(y0[k]), efficiency=float(e0[k]))
             for k, s in enumerate(settings)]
    choke = [LimitPoint(setting=list(s.values), theta=s.theta, phi=s.phi, flow=float(x1[k]), pressure=float(y1[k]), efficiency=float(e1[k]),
                        vertical_to=min(s.choke_pressures) if s.choke_pressures else None)
             for k, s in enumerate(settings)]
    if margin <= 0:
        return surge, choke, None
    target = y0 / (1.0 + margin)
    lo, hi = np.zeros(n), np.ones(n)
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        above = curves.evaluate_xy(idx, mid)[1] > target
        lo, hi = np.where(above, mid, lo), np.where(above, hi, mid)
    xm, ym, em = curves.evaluate(idx, hi)
    reach = y1 <= target
    line = [LimitPoint(setting=list(s.values), theta=s.theta, phi=s.phi, flow=float(xm[k]), pressure=float(ym[k]), efficiency=float(em[k]))
            for k, s in enumerate(settings) if reach[k]]
    return surge, choke, line


def _warn_beyond_gsp(settings: list[Setting], beta_values: int, warnings: list[Diagnostic]) -> None:
    """The GasTurb export writes one file per value of the leading settings, its Surge and Choke Line tables one
    flow per speed line: more lines than GSP reads in a table are said (the file is still written: GasTurb and
    GSPy read longer tables), and so are fewer speed lines or beta values than GSPy can load."""
    groups: dict[tuple, int] = {}
    for s in settings:
        groups[tuple(s.values[:-1])] = groups.get(tuple(s.values[:-1]), 0) + 1
    _warn_below_gspy(groups, beta_values, warnings)
    if min(groups.values()) < PYCYCLE_MIN_SPEED_LINES:
        warnings.append(Diagnostic(
            code="pycycle_export_not_possible", message="No map_pycycle.py: the map has one speed line"
            + (" per value of the other settings" if len(groups) > 1 else "") + ", and pyCycle's CompressorMap "
            f"interpolates its tables over the speed, which needs at least {PYCYCLE_MIN_SPEED_LINES} speed lines "
            "(OpenMDAO refuses the table). The GasTurb table and map_beta.csv are written.",
            details={"speed_lines": min(groups.values()), "minimum": PYCYCLE_MIN_SPEED_LINES}))
    over = {k: n for k, n in groups.items() if n > GSP_MAX_ARGUMENTS}
    if over:
        key, n = max(over.items(), key=lambda kv: kv[1])
        where = f" ({', '.join(f'{v:g}' for v in key)})" if key else ""
        rows = f"; its {n} speed rows are more than GSP's {GSP_MAX_PARAMETERS} too" if n > GSP_MAX_PARAMETERS else ""
        warnings.append(Diagnostic(
            code="gasturb_beyond_gsp_limits", message=f"{n} speed lines in one GasTurb map file{where}: its Surge "
            f"Line and Choke Line tables hold one flow per line, and GSP reads at most {GSP_MAX_ARGUMENTS} values a "
            f"table (GasTurb and GSPy read more){rows}. For GSP, submit at most {GSP_MAX_ARGUMENTS} speed lines a "
            "file.",
            details={"speed_lines": n, "limit": GSP_MAX_ARGUMENTS, "rows_limit": GSP_MAX_PARAMETERS,
                     "files": [list(k) for k in over][:100]}))


# pyCycle's CompressorMap interpolates (alpha, Nc, R-line) linearly: OpenMDAO refuses a table with one value along an
# axis ('There are 1 points in a data dimension'); a single alpha is repeated, as pyCycle's maps do, a speed cannot be
PYCYCLE_MIN_SPEED_LINES = 2

# GSPy reads a compressor map into scipy's cubic grid interpolators over (speed, beta), which need four values
# along each axis: with fewer its map reader raises, and the file cannot be used there at all.
GSPY_MIN_VALUES = 4


def _warn_below_gspy(groups: dict[tuple, int], beta_values: int, warnings: list[Diagnostic]) -> None:
    few = {k: n for k, n in groups.items() if n < GSPY_MIN_VALUES}
    if not few and beta_values >= GSPY_MIN_VALUES:
        return
    n = min(few.values()) if few else min(groups.values())
    what = ([f"{n} speed line(s) in a file"] if few else []) + \
        ([f"{beta_values} beta values"] if beta_values < GSPY_MIN_VALUES else [])
    warnings.append(Diagnostic(
        code="gasturb_below_gspy_minimum", message=f"The GasTurb map export has {' and '.join(what)}: GSPy "
        f"interpolates a map cubically over speed and beta and needs at least {GSPY_MIN_VALUES} of each, so GSPy "
        f"cannot load it (this service's reader and pyCycle's linear tables can). For GSPy, fit at least "
        f"{GSPY_MIN_VALUES} speed lines a file and options.beta_grid.lines of at least {GSPY_MIN_VALUES}.",
        details={"speed_lines": n, "beta_values": beta_values, "minimum": GSPY_MIN_VALUES,
                 "files": [list(k) for k in few][:100]}))


# On a compressor's map a faster speed line lies at larger flows at every beta (the surge and choke lines rise with
# the speed): pyCycle's nine maps and GasTurb's samples keep that within 0.8 % of the flow. A line further back is a
# speed value typed wrong or lines that cross, which the exports and the (speed, beta) query interpolate as given.
SPEED_ORDER_TOLERANCE = 0.02


def _warn_speed_lines_out_of_order(settings: list[Setting], flow: np.ndarray, beta: np.ndarray,
                                   warnings: list[Diagnostic]) -> None:
    groups: dict[tuple, list[int]] = {}
    for k, s in enumerate(settings):
        groups.setdefault(tuple(s.values[:-1]), []).append(k)
    worst = None
    for ks in groups.values():
        ks = sorted(ks, key=lambda k: settings[k].values[-1])
        back = (flow[ks[:-1]] - flow[ks[1:]]) / np.abs(flow[ks[:-1]]).max(axis=1, keepdims=True)
        if back.size and back.max() > SPEED_ORDER_TOLERANCE and (worst is None or back.max() > worst[0]):
            i, j = np.unravel_index(int(np.argmax(back)), back.shape)
            worst = (float(back.max()), ks[i], ks[i + 1], int(j))
    if worst is None:
        return
    share, lo, hi, j = worst
    slow, fast = settings[lo], settings[hi]
    warnings.append(Diagnostic(
        code="speed_lines_out_of_order", message=f"The faster speed line {fast.label} lies at smaller flows than the "
        f"slower {slow.label}: at beta {beta[j]:.3g} its flow is {flow[hi, j]:.6g}, {100 * share:.0f} % of the line's "
        f"largest flow below the slower line's {flow[lo, j]:.6g}. On a compressor map faster lines lie at larger flows "
        "(surge and choke lines rise with the speed): is a speed value wrong, or do the lines cross? The exports and "
        "the (speed, beta) query interpolate between them as given.",
        details={"quantity": "settings", "slower": list(slow.values), "faster": list(fast.values),
                 "beta": float(beta[j]), "flows": [float(flow[lo, j]), float(flow[hi, j])]}))


def _warn_pressure_not_ratio(units, warnings: list[Diagnostic]) -> None:
    """pyCycle's PRmap and GasTurb's Pressure Ratio table hold ratios, and the cycle codes read them so: a map in
    kPa (a pressure rise, an outlet pressure) is written there in kPa, which they would take for ratios of 3 or
    300 without a word. The files state the unit beside the table; the report says it too."""
    unit = units.pressure if units is not None else None
    if unit is None or unit in ("1", "-"):
        return
    warnings.append(Diagnostic(
        code="exports_pressure_not_ratio", message=f"The cycle-code exports (map_pycycle.py's PRmap, "
        f"map_gasturb.map's Pressure Ratio table) hold the map's pressure in {unit}, not a pressure ratio: pyCycle, "
        "GasTurb and GSP read those tables as ratios p2/p1. Submit pressure ratios (a column 'PR [-]') for a map "
        "a cycle code can run.", details={"quantity": "pressure", "unit": unit}))


def beta_tables(curves: CurveSet, settings: list[Setting], option, units, warnings: list[Diagnostic]) -> BetaMap | None:
    """Every speed line tabulated on the beta grid (:mod:`~plantsolve.solvers.perfmap.beta_grid`); None, with a
    warning naming the line, when some beta line would cross a speed line twice."""
    ratio = units is not None and units.pressure in ("1", "-")
    try:
        table = tabulate(curves, option.lines, option.shape, ratio, option.spacing)
    except BetaGridError as e:
        s = settings[e.line]
        warnings.append(Diagnostic(
            code="beta_grid_not_possible", message=f"No beta grid (no cycle-code exports): setting {s.label}: "
            f"{e.reason}.", details={"values": list(s.values), "reason": e.reason}))
        return None
    lines = [BetaLine(setting=list(s.values), flow=table.flow[k].tolist(), pressure=table.pressure[k].tolist(),
                      efficiency=table.efficiency[k].tolist(), t=table.t[k].tolist(),
                      c_choke=float(table.c_choke[k]), c_surge=float(table.c_surge[k]),
                      table_pressure_max_rel_error=float(table.pressure_error[k]),
                      table_efficiency_max_abs_error=float(table.efficiency_error[k]))
             for k, s in enumerate(settings)]
    coarse = np.flatnonzero(table.pressure_error > PRESSURE_EXCESS)
    if coarse.size:
        worst = int(coarse[np.argmax(table.pressure_error[coarse])])
        warnings.append(Diagnostic(
            code="beta_grid_coarse", message=f"{coarse.size} speed line(s) depart from their table, read linearly "
            f"between its {option.lines} beta nodes, by more than {PRESSURE_EXCESS:.0%} in pressure (worst "
            f"{100 * table.pressure_error[worst]:.2f}% at setting {settings[worst].label}): more beta lines"
            f"{' or spacing adaptive' if option.spacing == 'even' else ''} bring the exports closer to the fit.",
            details={"values": [list(settings[k].values) for k in coarse[:100]],
                     "errors": table.pressure_error[coarse[:100]].tolist(), "lines": option.lines,
                     "spacing": option.spacing}))
    # a reader that takes flows within CHOKE_FLOW_TOLERANCE of a line's largest as its vertical choke segment
    # (this project's, for pyCycle's repeated choke flows) would read such nodes as one
    span = table.flow.max(axis=1) - table.flow.min(axis=1)
    close = [list(settings[k].values) for k in np.flatnonzero(table.flow[:, 0] - table.flow[:, 1]
                                                              <= CHOKE_FLOW_TOLERANCE * span)]
    if close:
        warnings.append(Diagnostic(
            code="beta_grid_choke_nodes", message=f"{len(close)} speed line(s) fall so steeply at choke that their "
            f"first two beta nodes lie within {CHOKE_FLOW_TOLERANCE:g} of the line's flow range: a reader that "
            "takes such flows as a vertical choke segment merges them; fewer beta lines avoid it.",
            details={"values": close[:100], "lines": option.lines}))
    _warn_beyond_gsp(settings, len(table.beta), warnings)
    _warn_pressure_not_ratio(units, warnings)
    _warn_speed_lines_out_of_order(settings, table.flow, table.beta, warnings)
    f = table.frame
    return BetaMap(shape=option.shape, exponent=f.p, vertex_flow=f.xv, vertex_pressure=f.yv, spacing=option.spacing,
                   beta=table.beta.tolist(), lines=lines,
                   table_pressure_max_rel_error=float(table.pressure_error.max()),
                   table_efficiency_max_abs_error=float(table.efficiency_error.max()))


def envelopes(curves: CurveSet, values: np.ndarray, opts, progress: Progress = no_progress) -> list[Envelope]:
    """§3, "The Envelope": for each inlet angle θ, the upper envelope of its characteristics
    interpolated over the diffuser positions φ, with φ(x) and η along it. In general: for each value of
    the other setting parameters, over the last one (one parameter: one envelope over it)."""
    envs = []
    last = values[:, -1]
    groups = sorted({tuple(v) for v in values[:, :-1].tolist()})
    for j, fixed in enumerate(groups):
        progress(0.61 + 0.01 * j / len(groups), f"envelope {j + 1} of {len(groups)}")
        members = [i for i in range(len(values)) if tuple(values[i, :-1].tolist()) == fixed]
        e = envelope(curves, members, last, opts.envelope_curves, opts.envelope_points)
        envs.append(Envelope(fixed=list(fixed), theta=fixed[0] if len(fixed) == 1 else None,
                             flow=e["flow"].tolist(),
                             pressure=_nan_to_none(e["pressure"])[0],
                             phi=_nan_to_none(e["phi"])[0],
                             efficiency=_nan_to_none(e["efficiency"])[0]))
    return envs


def performance_map(curves: CurveSet, settings: list[Setting], values: np.ndarray, ranges, opts, progress: Progress,
                    warnings: list[Diagnostic]) -> tuple[PerformanceMap | None, np.ndarray]:
    """§4, "The Performance Map": triangulate the settings, then the maximum efficiency (and
    the θ, φ that reach it) at every grid node, exactly per triangle (or by the paper's
    binning, ``map_method: "binning"``). Returns the map (None when there is none) and the
    triangles."""
    triangles = np.zeros((0, 3), dtype=int)
    no_map = map_impossible(settings) if opts.map is None else None
    if opts.map is False or no_map:
        if no_map:
            warnings.append(Diagnostic(code="map_not_possible", message=f"No performance map: "
                                       f"{no_map}; characteristics and envelopes only, no inverse "
                                       "query for this job.", details={"reason": no_map}))
        else:
            warnings.append(Diagnostic(code="map_skipped", message="options.map is false: no "
                                       "performance map and no inverse query for this job."))
        return None, triangles
    triangles, kind = map_simplices(values)
    if kind == "faces":
        warnings.append(Diagnostic(
            code="three_parameter_map", message=f"Three setting parameters: the map is the maximum over the "
            f"{len(triangles)} faces of the Delaunay tetrahedra of the settings (where a maximum over a "
            "tetrahedron lies); 'triangles' lists the faces.", details={"faces": len(triangles)}))
    if kind == "chain":
        warnings.append(Diagnostic(
            code="one_parameter_map", message=f"The {len(settings)} settings lie on one line (one setting "
            "parameter, e.g. speed): the map interpolates between neighbouring lines only; "
            "'triangles' lists them as (i, j, j).", details={"segments": len(triangles)}))
    if len(triangles) == 0:
        raise SolverError("triangulation", "no non-degenerate triangle of settings",
                          {"n_settings": len(settings)})
    gx, gy = grid_axes(ranges, *opts.grid)
    if opts.map_method == "exact":
        t = np.linspace(0.0, 1.0, opts.t_samples)
        eta, val_map = exact_map(curves, triangles, values, t, gx, gy, ranges,
                                        progress, 0.62, 0.98)
    else:
        eta, val_map = binned_map(curves, triangles, values, gx, gy, ranges,
                                         m_t=opts.t_samples - 1)
    pmap = PerformanceMap(method=opts.map_method, flow=gx.tolist(), pressure=gy.tolist(),
                          efficiency=_nan_to_none(eta), settings=[_nan_to_none(v) for v in val_map],
                          theta=_nan_to_none(val_map[0]) if len(val_map) == 2 else None,
                          phi=_nan_to_none(val_map[1]) if len(val_map) == 2 else None, t_samples=opts.t_samples,
                          reachable_fraction=float(np.mean(np.isfinite(eta))))
    if not np.isfinite(eta).any():
        warnings.append(Diagnostic(
            code="map_empty", message="No grid node of the map is reachable: the "
            "characteristics sweep no area in (flow, pressure) (e.g. all pressures equal); "
            "every inverse query will be infeasible.",
            details={"pressure_range": [ranges[2], ranges[3]]}))
    return pmap, triangles


def solve(value: PerfmapInput | PerfmapRequest, progress: Progress = no_progress) -> Solved:
    """Characteristics, envelopes, surge and choke lines and (options.map) the maximum-efficiency map, from the
    loaded input (``SPEC.load``; a request is loaded first)."""
    return Solved(_performance(loaded(value), progress))


def _coefficient_units(family: str, n: int, units) -> list[str | None]:
    """The unit of each public pressure coefficient of a family (``_public_coefficients``)."""
    if family == "concave":
        return [units.flow] * (n // 2) + [units.pressure] * (n - n // 2)
    if family == "log":  # a log(b - x) + c: b is a flow
        return [units.pressure, units.flow, units.pressure]
    return [units.pressure] * n


def _c_unit(units, exponent: int) -> str | None:
    """The unit of a beta line's c in y - y_v = c (x - x_v)^p."""
    if units.flow is None or units.pressure is None:
        return None
    flow = units.flow if exponent == 1 else f"({units.flow})^{exponent}"
    return f"({units.pressure})/{flow}" if units.pressure != "1" else f"1/{flow}"


def _performance(value: PerfmapInput, progress: Progress) -> PerfmapResult:
    request, units, settings = value.internal, value.units, value.settings
    opts = request.options
    progress(0.02, "input checked")
    warnings: list[Diagnostic] = list(request.upload_warnings) + list(value.warnings)

    ch = fit_characteristics(settings, opts.fit == "minimax", opts.concave_efficiency, progress)
    progress(0.6, "choosing the curve families")
    table = error_table(ch)
    family, pressure_choice, eta_choice, details = choose_families(ch, settings, opts, warnings)
    eta_table = efficiency_error_table(ch, settings, eta_choice)
    out_settings = setting_results(ch, settings, pressure_choice, eta_choice, opts, warnings)
    for fit in out_settings:
        fit.pressure_coefficient_units = _coefficient_units(fit.family, len(fit.pressure_coefficients), units)

    progress(0.605, "per-setting results")
    curves = curveset_from_fits(out_settings)
    values = np.array([s.values for s in settings], dtype=float).reshape(len(settings), -1)
    envs = envelopes(curves, values, opts, progress)
    surge, choke, margin_line = limit_lines(curves, settings, opts.surge_margin)
    beta_map = beta_tables(curves, settings, opts.beta_grid, units, warnings)
    if beta_map is not None:
        beta_map.c_unit = _c_unit(units, beta_map.exponent)
        if (misplaced := last_setting_not_speed(request.setting_names, units.settings)) is not None:
            warnings.append(misplaced)
        elif (scaled := exports_speed_not_relative(request.setting_names, units.settings,
                                                   [s.values[-1] for s in settings])) is not None:
            warnings.append(scaled)
    progress(0.62, "surge and choke lines and the beta grid done")

    ranges = curve_ranges(curves)
    pmap, triangles = performance_map(curves, settings, values, ranges, opts, progress, warnings)
    progress(1.0, "done")

    report = Report(status="warning" if warnings else "ok",
                    message=f"{len(settings)} settings fitted with family '{family}' "
                    f"({opts.fit}); {len(envs)} envelope(s)"
                    + (f"; map {opts.grid[0]}x{opts.grid[1]} over {len(triangles)} triangles"
                       if pmap else ""),
                    warnings=warnings, details={"family_choice": details, "source": value.source})
    return PerfmapResult(report=report, units=units, setting_names=list(request.setting_names),
                         setting_units=request.setting_units, family=family, fit=opts.fit, settings=out_settings,
                         error_table=table, efficiency_error_table=eta_table, envelopes=envs,
                         surge_line=surge, choke_line=choke, surge_margin_line=margin_line,
                         triangles=triangles.tolist(), map=pmap, beta_map=beta_map, flow_range=[ranges[0], ranges[1]],
                         pressure_range=[ranges[2], ranges[3]])
