"""Inspection against a nominal LRA (beyond the paper; what tube shops use every day).

The nominal tube is built in its own frame (start at the origin, identity frame). The
measured centreline is matched to it in both walking directions: a rigid motion is
initialised by Kabsch on arc-length correspondences and refined by least squares on the
distance of measured centreline samples to the nominal centreline. The direction with the
smaller rms wins. Reported: per-bend deviations (measured − nominal), the sheath deviation
(max distance of the measured centreline from the aligned nominal one) and the corrected
LRA for the bender: corrected = nominal + damping · (nominal − measured) for bend angle,
rotation and length (springback compensation); radii are tooling and stay nominal.

With equal bend counts every LRA row is checked per field against the tolerances (``tolerances``), both
tube ends by their distance from the aligned nominal ends, and the corrections for the next part are given
per row (``corrections``). The nominal may be given as LRA rows, XYZ-CLR points or a CSV (``nominal_files``).
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation

from plantsolve.schemas.common import Diagnostic
from plantsolve.schemas.tube import Alignment, BendDeviation, Inspection, LraRow, TubeOptions
from plantsolve.solvers.geometry import kabsch, quaternion, rotvec_matrix, wrap_angle
from plantsolve.solvers.tube import corrections as next_part
from plantsolve.solvers.tube import tolerances as tol_check
from plantsolve.solvers.tube.lra import model_from_rows, model_rows
from plantsolve.solvers.tube.model import (
    TubeModel,
    build_spine,
    closest_points,
    distance_frames,
    reverse_model,
    sample_centreline,
    spine_distance,
)
from plantsolve.solvers.tube.nominal_files import resolve_nominal

QUICK_NFEV = 15  # alignment steps that decide the walking direction


def wrap_degrees(a: float) -> float:
    return float(wrap_angle(a, 360.0))


def _resample(pts: np.ndarray, m: int) -> np.ndarray:
    s = np.concatenate([[0], np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))])
    u = np.linspace(0, s[-1], m)
    return np.column_stack([np.interp(u, s, pts[:, k]) for k in range(3)])


def align(measured: TubeModel, nominal: TubeModel,
          max_nfev: int | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rigid motion (R, t) with R·nominal + t ≈ measured; distances of measured samples."""
    step = max(measured.pipe_radius, 1e-9) * 0.5
    total = build_spine(measured).length.sum()
    step = max(step, total / 400)
    qm, _ = sample_centreline(measured, step)
    qn, _ = sample_centreline(nominal, step)
    a, b = _resample(qn, 200), _resample(qm, 200)
    R0, t0, _ = kabsch(a, b)
    sp_n = build_spine(nominal)
    scale = np.r_[np.full(3, 1.0), np.full(3, step)]
    frames = distance_frames(sp_n)
    cache: dict = {}
    h = 1e-7
    steps = np.eye(3) * h

    def evaluate(x):
        """Distances and their Jacobian. d(distance)/d(point) is the unit vector from the
        closest nominal point (envelope theorem, valid on arcs, lines and segment ends);
        the point's dependence on the rotation vector is differentiated numerically on the
        3×3 matrix only, which costs nothing."""
        key = x.tobytes()
        if key not in cache:
            cache.clear()
            M = (rotvec_matrix(x[:3]) @ R0).T
            u = qm - (t0 + x[3:])
            local = u @ M.T  # R^T (q − t)
            d, idx = spine_distance(local, sp_n, frames=frames)
            e = local - closest_points(local, sp_n, idx)
            e /= np.maximum(d, 1e-300)[:, None]
            J = np.empty((len(qm), 6))
            for j in range(3):
                dM = ((rotvec_matrix(x[:3] + steps[j]) - rotvec_matrix(x[:3] - steps[j])) @ R0).T / (2 * h)
                J[:, j] = np.einsum("nk,nk->n", e, u @ dM.T)
            J[:, 3:] = -e @ M
            cache[key] = (d, J)
        return cache[key]

    def res(x):
        return evaluate(x)[0]

    def jac(x):
        return evaluate(x)[1]

    sol = least_squares(res, np.zeros(6), jac=jac, method="lm", x_scale=scale, max_nfev=max_nfev)
    R = rotvec_matrix(sol.x[:3]) @ R0
    return R, t0 + sol.x[3:], res(sol.x)


def options_without_nominal(opts: TubeOptions) -> Diagnostic | None:
    """A warning naming the inspection's options a request sets that nothing reads (``inspection_tolerances``, a
    ``damping``, ``springback_model`` or ``nominal_format`` other than the default, without a nominal; a
    ``nominal_format`` with a nominal given as ``nominal`` or ``nominal_xyz_clr``, which it does not describe):
    they were ignored without a word (tolerances sent for an inspection whose nominal was left out)."""
    changed = [name for name in ("damping", "springback_model", "nominal_format")
               if getattr(opts, name) != TubeOptions.model_fields[name].default]
    if opts.nominal_csv is None and "nominal_format" in changed and \
            (opts.nominal is not None or opts.nominal_xyz_clr is not None):
        given = "nominal" if opts.nominal is not None else "nominal_xyz_clr"
        return Diagnostic(code="inspection_options_ignored", message=(
            f"options.nominal_format ({opts.nominal_format!r}) says how to read options.nominal_csv, and the nominal "
            f"is given as options.{given}: it was ignored."), details={"options": ["nominal_format"]})
    if opts.nominal is not None or opts.nominal_xyz_clr is not None or opts.nominal_csv is not None:
        return None
    set_here = opts.inspection_tolerances.model_dump(exclude_none=True)
    named = [f"inspection_tolerances ({', '.join(set_here)})"] if set_here else []
    named += changed
    if not named:
        return None
    return Diagnostic(code="inspection_options_ignored", message=(
        f"options {', '.join(named)} apply to an inspection, and the request gives no nominal (options.nominal, "
        "nominal_xyz_clr or nominal_csv): they were ignored, no part inspected. Give the nominal to inspect the "
        "tube against it."), details={"options": [n.split(" ")[0] for n in named]})


def inspect_request(measured: TubeModel, opts: TubeOptions, units: str,
                    measured_rows: list[LraRow] | None = None) -> Inspection | None:
    """The inspection the options ask for (None without a nominal)."""
    nominal = resolve_nominal(opts, units)
    if nominal is None:
        return None
    warnings = list(nominal.warnings) + nominal_mixups(measured, nominal.rows, units) + tol_check.implausible(
        opts.inspection_tolerances, measured.pipe_radius, nominal.rows, units)
    return inspect(measured, nominal.rows, opts.damping, opts, units, nominal.source, warnings, measured_rows)


# unit pairs whose ratio a nominal typed in the other unit shows (the larger per the smaller)
UNIT_RATIOS = {10.0: "cm and mm", 25.4: "inches and mm", 1000.0: "m and mm", 304.8: "ft and mm", 12.0: "ft and inches",
               39.37: "m and inches", 100.0: "m and cm", 2.54: "inches and cm"}
UNIT_RATIO_SLACK = 1.15  # a measured tube is within a few % of its nominal; a unit mix-up is a whole factor off


def nominal_mixups(measured: TubeModel, nominal: list[LraRow], units: str) -> list[Diagnostic]:
    """Warnings on a nominal that does not fit the scanned tube the way a mix-up would make it miss: bend angles
    in radians in a degree column, lengths in another unit than the stated one, a CLR smaller than the tube's
    radius (no bender makes it). The inspection still compares the nominal as given; these say why it fails."""
    got = model_rows(measured)
    meas, nom = got[:-1], nominal[:-1]
    out: list[Diagnostic] = []
    a_nom = np.array([r.angle for r in nom])
    a_meas = np.array([r.angle for r in meas])
    if len(a_nom) and len(a_meas) and a_nom.max() <= np.pi * (1 + 1e-6) and np.median(a_meas) > 5.0:
        as_deg = np.degrees(a_nom)
        if len(a_nom) == len(a_meas):
            off_deg = min(np.abs(a_meas - a_nom).sum(), np.abs(a_meas[::-1] - a_nom).sum())
            off_rad = min(np.abs(a_meas - as_deg).sum(), np.abs(a_meas[::-1] - as_deg).sum())
        else:
            off_deg = abs(np.median(a_meas) - np.median(a_nom))
            off_rad = abs(np.median(a_meas) - np.median(as_deg))
        if off_rad < 0.25 * off_deg:
            out.append(Diagnostic(code="nominal_angles_in_radians", message=(
                f"The nominal's bend angles ({', '.join(f'{a:.4g}' for a in a_nom[:6])}) are all below π and read as "
                f"degrees; as radians they would be {', '.join(f'{a:.1f}' for a in as_deg[:6])}°, near the measured "
                f"{', '.join(f'{a:.1f}' for a in a_meas[:6])}°. Radians in a degree column? Name the column "
                "angle_rad (or give degrees)."), details={"nominal_angles": a_nom.tolist(),
                                                          "as_degrees": as_deg.tolist(),
                                                          "measured_angles": a_meas.tolist()}))
    # the scan may run from either end: the rows are paired in the direction whose lengths agree best
    ratio = min((_length_ratio(nom, rows[:-1], measured.pipe_radius)
                 for rows in (got, model_rows(reverse_model(measured)))), key=lambda r: abs(np.log(r)))
    # one mix-up named, the nearest unit ratio (the bands of 10 and 12 overlap)
    factor, pair, bigger = min(((f, p, b) for f, p in UNIT_RATIOS.items() for b in ("nominal", "measured")),
                               key=lambda c: abs(np.log((ratio if c[2] == "nominal" else 1.0 / ratio) / c[0])))
    if abs(np.log((ratio if bigger == "nominal" else 1.0 / ratio) / factor)) < np.log(UNIT_RATIO_SLACK):
        out.append(Diagnostic(code="nominal_unit_mismatch", message=(
            f"The nominal's lengths (CLRs and the straights between bends) are {ratio:.4g} × the measured "
            f"ones (median): {'larger' if bigger == 'nominal' else 'smaller'} by the ratio of {pair} "
            f"({factor:g}). Is the nominal in another unit than it states (its header's unit, or {units} "
            "when it names none)?"), details={"ratio": ratio, "unit_ratio": factor, "units": units}))
    diameter = _clr_as_diameter(nom, (got, model_rows(reverse_model(measured))), units)
    if diameter is not None:
        out.append(diameter)
    mirrored = _rotations_mirrored(nominal, (got, model_rows(reverse_model(measured))))
    if mirrored is not None:
        out.append(mirrored)
    small = [(i + 1, r.bend_radius) for i, r in enumerate(nom) if 0 < r.bend_radius < measured.pipe_radius]
    if small:
        out.append(Diagnostic(code="implausible_nominal_clr", message=(
            f"Nominal rows {', '.join(str(i) for i, _ in small[:10])}: a CLR of "
            f"{', '.join(f'{c:g}' for _, c in small[:10])} {units} is below the tube's radius "
            f"({measured.pipe_radius:.4g} {units}); no bender makes such a bend. The tube's radius typed as the "
            "CLR, or another unit?"), details={"rows": [i for i, _ in small], "clr": [c for _, c in small],
                               "pipe_radius": measured.pipe_radius}))
    return out


DIAMETER_SLACK = 0.12  # the nominal's CLRs this near twice the measured ones, its straights this near them


def _clr_as_diameter(nom: list[LraRow], directions, units: str) -> Diagnostic | None:
    """A warning when the nominal's CLRs are twice the measured bend radii while its straights between bends are
    the measured ones: the bend's diameter (or the die's) typed in the CLR column. A unit mix-up scales both."""
    for rows in directions:
        meas = rows[:-1]
        if len(meas) != len(nom) or not nom:
            return None
        clr = [n.bend_radius / m.bend_radius for n, m in zip(nom, meas) if n.bend_radius > 0 and m.bend_radius > 0]
        inner = [n.length / m.length for n, m in zip(nom[1:], meas[1:]) if n.length > 0 and m.length > 0]
        if not clr or not inner:
            return None
        clr_ratio, length_ratio = float(np.median(clr)), float(np.median(inner))
        if abs(clr_ratio / 2.0 - 1.0) < DIAMETER_SLACK and abs(length_ratio - 1.0) < DIAMETER_SLACK:
            return Diagnostic(code="nominal_clr_as_diameter", message=(
                f"The nominal's CLRs ({', '.join(f'{r.bend_radius:g}' for r in nom[:6])} {units}) are {clr_ratio:.3g} × "
                f"the measured bend radii ({', '.join(f'{m.bend_radius:.4g}' for m in meas[:6])} {units}) while its "
                f"straights match them ({length_ratio:.3g} ×): a diameter in the CLR column? The CLR is the "
                "centreline's bend radius; every CLR check fails against a diameter."),
                details={"clr_ratio": clr_ratio, "length_ratio": length_ratio,
                         "nominal_clr": [r.bend_radius for r in nom], "measured_clr": [m.bend_radius for m in meas]})
    return None


SIGN_SHOWN_DEG = 10.0  # a rotation this far from 0° and 180° shows its sign through any scan's noise


def _wrapped(degrees: np.ndarray) -> np.ndarray:
    return (degrees + 180.0) % 360.0 - 180.0


def _rotations_mirrored(nominal: list[LraRow], directions) -> Diagnostic | None:
    """A warning when the nominal's rotations are the measured ones with the other sign, in the walking direction
    that fits them best: a rotation counted left-handed (some benders and CAD programs count it clockwise looking
    along the tube), which describes the mirror image of the part. Walking a tube from its other end reverses its
    rotations' order, not their signs, so a part that is its own mirror image walked backwards says nothing."""
    r_nom = np.array([r.rotation for r in nominal[1:-1]], float)
    fits = []  # (mean deviation as given, negated, the measured rotations) per walking direction
    for rows in directions:
        if len(rows) != len(nominal):
            continue
        r_meas = np.array([r.rotation for r in rows[1:-1]], float)
        telling = (np.abs(_wrapped(r_meas)) > SIGN_SHOWN_DEG) & (np.abs(_wrapped(r_meas)) < 180.0 - SIGN_SHOWN_DEG)
        if not telling.any():
            return None
        fits.append((float(np.abs(_wrapped(r_nom - r_meas))[telling].mean()),
                     float(np.abs(_wrapped(r_nom + r_meas))[telling].mean()), r_meas))
    if not fits:
        return None
    as_given = min(f[0] for f in fits)
    negated, _, shown = min(((f[1], k, f[2]) for k, f in enumerate(fits)), key=lambda f: f[:2])
    if not (negated < 0.25 * as_given and as_given > SIGN_SHOWN_DEG):
        return None
    return Diagnostic(code="nominal_rotations_mirrored", message=(
        f"The nominal's rotations ({', '.join(f'{r:g}' for r in r_nom[:6])}°) are the measured ones "
        f"({', '.join(f'{r:.1f}' for r in shown[:6])}°) with the other sign (off by {negated:.1f}° on average that "
        f"way, {as_given:.1f}° as given): counted left-handed? This project's rotations turn right-handed about the "
        "tangent; a nominal counted the other way describes the part's mirror image, every such row fails, and "
        "corrections.csv turns each by twice its angle. Negate the nominal's rotations if the bender counts them "
        "clockwise."), details={"nominal_rotations": r_nom.tolist(), "measured_rotations": shown.tolist(),
                                "mean_deviation_as_given": as_given, "mean_deviation_negated": negated})


def _length_ratio(nom: list[LraRow], meas: list[LraRow], pipe_radius: float) -> float:
    """The median ratio of the nominal's lengths to the measured ones, row by row: the CLRs and the straights
    between bends (whole in the scan; the end ones may not be); the median CLRs' ratio when the bend counts
    differ; 1 when nothing compares."""
    if len(nom) == len(meas):
        ratios = [n.bend_radius / m.bend_radius for n, m in zip(nom, meas) if m.bend_radius > 0 and n.bend_radius > 0]
        ratios += [n.length / m.length for n, m in zip(nom[1:], meas[1:]) if m.length > pipe_radius and n.length > 0]
    elif nom and meas:
        ratios = [float(np.median([r.bend_radius for r in nom]) / np.median([r.bend_radius for r in meas]))]
    else:
        ratios = []
    return float(np.exp(np.median(np.log(ratios)))) if ratios else 1.0


def reversed_rows(rows: list[LraRow]) -> list[LraRow]:
    """What the samples determine of each row (sigmas, bounds, ``undetermined``) walked from the other end: row
    i's straight and rotation are row n − i's, its bend is bend n − 1 − i's."""
    n = len(rows) - 1
    out = []
    for i in range(n + 1):
        s, b = rows[n - i], rows[n - 1 - i] if i < n else None
        fields = {"length": s, "rotation": s if 0 < i < n else None, "angle": b, "bend_radius": b}
        undetermined = [f for f, src in fields.items() if src is not None and f in src.undetermined]
        out.append(LraRow(length=s.length, sigma_length=s.sigma_length, length_bound=s.length_bound,
                          sigma_rotation=s.sigma_rotation if 0 < i < n else (0.0 if i == 0 and n else None),
                          sigma_angle=b.sigma_angle if b else None, angle_bound=b.angle_bound if b else None,
                          sigma_bend_radius=b.sigma_bend_radius if b else None, undetermined=undetermined,
                          determined=not undetermined if s.determined is not None else None))
    return out


def _with_knowledge(rows: list[LraRow], known: list[LraRow] | None) -> list[LraRow]:
    """The measured rows (values from the aligned model) with what the samples determine of each."""
    if known is None or len(known) != len(rows):
        return rows
    keep = ("sigma_length", "sigma_rotation", "sigma_angle", "sigma_bend_radius", "determined", "undetermined",
            "length_bound", "angle_bound")
    return [r.model_copy(update={k: getattr(k_row, k) for k in keep}) for r, k_row in zip(rows, known)]


def _verdict(matched: bool, rows, ends) -> tuple[str, list[int], list[int]]:
    failed = [r.row for r in rows if r.ok is False]  # null: no verdict, neither a pass nor a failure
    undetermined = [r.row for r in rows if r.undetermined]
    if not matched:
        return "not_comparable", [], []
    if failed or any(e.ok is False for e in ends):
        return "fail", failed, undetermined
    if undetermined or not all(e.determined for e in ends):
        return "not_determined", failed, undetermined
    return "pass", failed, undetermined


def withdraw_verdicts(ins: Inspection, fields: dict[int, list[str]] | None = None) -> None:
    """No verdict on ``fields`` (measured LRA row, 0-based in the result's walking direction -> its fields), or on
    every field and end point when None: fields no sample shows (a stretch the scan did not see, ``scan_gap``) are
    the fit's guess, and a scan that may hold two pieces was fitted as one tube through bends no sample shows, so
    one nominal aligned to it says nothing row by row."""
    n = len(ins.rows) - 1
    picked: dict[int, set[str]] = {}
    for k, names in (fields or {}).items():
        for f in names:  # a reversed walk: row i's straight is row n - i's, its bend bend n - 1 - i's
            i = k if not ins.reversed else (n - k if f in ("length", "rotation") else n - 1 - k)
            picked.setdefault(i, set()).add(f)
    for i, row in enumerate(ins.rows):
        names = [f for f in ("length", "rotation", "angle", "bend_radius") if getattr(row, f)
                 and (fields is None or f in picked.get(i, ()))]
        for f in names:
            check = getattr(row, f)
            check.ok, check.determined = None, False
        row.failed = [f for f in row.failed if f not in names]
        row.undetermined = [f for f in ("length", "rotation", "angle", "bend_radius")
                            if f in row.undetermined or f in names]
        row.ok = tol_check.row_ok(row.failed, row.undetermined)
    if fields is None:
        for end in ins.end_points:
            end.ok, end.determined = None, False
    ins.verdict, ins.failed_rows, ins.undetermined_rows = _verdict(ins.matched, ins.rows, ins.end_points)


def inspect(measured: TubeModel, nominal_rows: list[LraRow], damping: float, opts: TubeOptions | None = None,
            units: str = "mm", source: str = "nominal: LRA rows",
            warnings: list[Diagnostic] | None = None, measured_rows: list[LraRow] | None = None) -> Inspection:
    """``measured_rows``: the result's LRA rows of ``measured`` (sigmas, bounds, fields not determined), in its
    own walking direction; without them every field is taken as determined."""
    nominal = model_from_rows(nominal_rows, measured.pipe_radius)
    best = None
    cands = [(False, measured), (True, reverse_model(measured))]
    # a short alignment tells the walking direction apart when one is clearly worse; only
    # close calls get the full alignment in both directions
    quick = [float(np.sqrt(np.mean(align(m, nominal, max_nfev=QUICK_NFEV)[2] ** 2))) for _, m in cands]
    if max(quick) > 2.0 * min(quick):
        cands = [cands[int(np.argmin(quick))]]
    for reversed_, m in cands:
        R, t, d = align(m, nominal)
        rms = float(np.sqrt(np.mean(d ** 2)))
        same = m.n_bends == nominal.n_bends
        key = (not same, rms)
        if best is None or key < best[0]:
            best = (key, reversed_, m, R, t, d)
    _, reversed_, m, R, t, d = best
    known = reversed_rows(measured_rows) if reversed_ and measured_rows else measured_rows
    meas_rows = _with_knowledge(model_rows(m), known)
    matched = m.n_bends == nominal.n_bends
    bends: list[BendDeviation] = []
    corrected = [row.model_copy() for row in nominal_rows]
    last_length = None
    if matched:
        n = nominal.n_bends
        for i in range(n):
            mr, nr = meas_rows[i], nominal_rows[i]
            bends.append(BendDeviation(bend=i + 1, angle=mr.angle - nr.angle,
                                       rotation=wrap_degrees(mr.rotation - nr.rotation) if i else 0.0,
                                       length=mr.length - nr.length, bend_radius=mr.bend_radius - nr.bend_radius))
            ang = nr.angle - damping * (mr.angle - nr.angle)
            rot = wrap_degrees(nr.rotation - damping * wrap_degrees(mr.rotation - nr.rotation)) if i else 0.0
            corrected[i] = LraRow(length=max(nr.length - damping * (mr.length - nr.length), 0.0), rotation=rot,
                                  angle=float(np.clip(ang, 0.0, 359.999)), bend_radius=nr.bend_radius)
        last_length = meas_rows[n].length - nominal_rows[n].length
        corrected[n] = LraRow(length=max(nominal_rows[n].length - damping * last_length, 0.0), rotation=0.0,
                              angle=0.0, bend_radius=0.0)
    quat = [float(v) for v in quaternion(Rotation.from_matrix(R), positive_w=True)]
    opts = opts or TubeOptions()
    tol = tol_check.resolved(opts.inspection_tolerances, units)
    sp_n, sp_m = build_spine(nominal), build_spine(m)
    nominal_ends = np.array([t, R @ sp_n.end[-1] + t])
    rows, fixes, fits = [], [], []
    if matched:
        rows = tol_check.check_rows(nominal_rows, meas_rows, tol)
        fixes, fits = next_part.corrections(nominal_rows, meas_rows, opts.springback_model)
    short = tuple(bool(rows) and tol_check.stops_short(rows[k].length) for k in (0, -1))
    reach = tuple(tol_check.PROVEN * (r.length.sigma or 0.0) if r.length.bound == "lower" else 0.0
                  for r in (rows[0], rows[-1])) if rows else (0.0, 0.0)
    ends = tol_check.check_end_points(nominal_ends, np.array([sp_m.start[0], sp_m.end[-1]]), tol, short, reach)
    verdict, failed, undetermined = _verdict(matched, rows, ends)
    return Inspection(matched=matched, nominal_bends=nominal.n_bends, measured_bends=m.n_bends, reversed=reversed_,
                      measured_lra=meas_rows, bends=bends, last_length=last_length, sheath_deviation=float(d.max()),
                      sheath_rms=float(np.sqrt(np.mean(d ** 2))),
                      alignment=Alignment(translation=[float(v) for v in t], quaternion=quat),
                      corrected_lra=corrected, tolerances=tol, rows=rows, end_points=ends, verdict=verdict,
                      failed_rows=failed, undetermined_rows=undetermined, corrections=fixes, springback_fits=fits,
                      nominal_source=source, warnings=list(warnings or []))
