"""Semantic input checks (fast; the job domain runs them once, at submission)."""

from __future__ import annotations

from types import MappingProxyType

import numpy as np
from scipy.spatial import cKDTree

from plantsolve.schemas.common import MAX_COORDINATE, Diagnostic
from plantsolve.solvers.base import FieldError, InputRejected
from plantsolve.solvers.length_units import SIZES
from plantsolve.solvers.tube import local_fit
from plantsolve.solvers.tube.nominal_files import nominal_errors
from plantsolve.solvers.tube.scan import TubeScan

MIN_POINTS = 100
# a coordinate with fewer distinct values puts every sample on that many parallel planes: a table's setting
# column (speed lines, angles), not a scan, whose coordinates vary continuously (even one rounded to 1 mm has
# hundreds of values over a tube)
MIN_LEVELS = 12


def check_points(pts: np.ndarray, loc: tuple) -> None:
    if pts.ndim != 2 or pts.shape[1] != 3:
        raise InputRejected([FieldError(loc=loc, msg="points must be an (N, 3) array")])
    if len(pts) < MIN_POINTS:
        raise InputRejected([FieldError(loc=loc, msg=f"at least {MIN_POINTS} points are needed, got {len(pts)}")])
    if not np.isfinite(pts).all():
        bad = int(np.flatnonzero(~np.isfinite(pts).all(1))[0])
        raise InputRejected([FieldError(loc=loc + (bad,), msg="coordinates must be finite")])
    if np.abs(pts).max() > MAX_COORDINATE:
        bad = int(np.flatnonzero(np.abs(pts).max(1) > MAX_COORDINATE)[0])
        raise InputRejected([FieldError(loc=loc + (bad,), msg=f"coordinates must be within {MAX_COORDINATE:g} of the unit "
                                        "(the schema's bound for points)")])
    sample = pts if len(pts) <= 200_000 else pts[:: len(pts) // 200_000 + 1]
    c = sample - sample.mean(0)
    s = np.linalg.svd(c.T @ c / len(c), compute_uv=False) ** 0.5
    if s[0] <= 0:
        raise InputRejected([FieldError(loc=loc, msg="all points coincide")])
    if s[1] < 1e-6 * s[0]:
        raise InputRejected([FieldError(loc=loc, msg="all points lie on a line: not a tube surface")])
    if s[2] < 1e-6 * s[0]:
        raise InputRejected([FieldError(loc=loc, msg="all points are coplanar: not a tube surface")])
    levels = [len(np.unique(sample[:, k])) for k in range(3)]
    if min(levels) < MIN_LEVELS:
        k = int(np.argmin(levels))
        raise InputRejected([FieldError(loc=loc, msg=(
            f"the {'xyz'[k]} coordinates take only {levels[k]} distinct values over {len(pts)} points: the samples "
            f"lie on {levels[k]} parallel planes, like the setting columns of a table (a compressor map's speed "
            "lines), not on a scanned surface; is this a file for another kind?"))])
    head = sample[:5000]
    if len(np.unique(np.round(head / (s[0] * 1e-9)), axis=0)) < min(MIN_POINTS, len(head)):
        raise InputRejected([FieldError(loc=loc, msg=f"fewer than {MIN_POINTS} distinct points")])


def check_input(scan: TubeScan) -> None:
    """Cross-field checks of a scan's request; raises InputRejected naming the field."""
    errors: list[FieldError] = []
    try:
        check_points(scan.points, ("points",))
    except InputRejected as exc:
        errors.extend(exc.errors)
    except ValueError as exc:
        errors.append(FieldError(loc=("points",), msg=str(exc)))
    o = scan.request.options
    if o.pipe_radius and o.bend_radius and o.bend_radius < o.pipe_radius:
        errors.append(FieldError(loc=("options", "bend_radius"),
                                 msg="bend radius must be at least the pipe radius"))
    if o.nominal:
        rows = o.nominal
        if len(rows) > 1 and rows[0].rotation != 0:
            errors.append(FieldError(loc=("options", "nominal", 0, "rotation"), msg="first rotation must be 0"))
        for i, row in enumerate(rows[:-1]):
            if row.angle <= 0:
                errors.append(FieldError(loc=("options", "nominal", i, "angle"),
                                         msg="every row but the last needs a bend angle > 0"))
            if row.bend_radius <= 0:
                errors.append(FieldError(loc=("options", "nominal", i, "bend_radius"),
                                         msg="every row but the last needs a bend radius > 0"))
        if rows[-1].angle != 0:
            errors.append(FieldError(loc=("options", "nominal", len(rows) - 1, "angle"),
                                     msg="the last row is the final straight: angle must be 0"))
    errors.extend(nominal_errors(o, scan.request.units))
    if not errors:
        errors.extend(options_against_scan(scan.points, o, scan.request.units))
    if errors:
        raise InputRejected(errors)


def scan_extent(pts: np.ndarray) -> float:
    """The diagonal of the samples' bounding box (a coordinate at a time: a reduction along the first axis of an
    (N, 3) array runs numpy's loop over rows of 3, ten times slower)."""
    return float(np.linalg.norm([pts[:, j].max() - pts[:, j].min() for j in range(3)]))


def sample_spacing(pts: np.ndarray, rng_seed: int = 0) -> float:
    """Median distance of a sample to its nearest neighbour. Large scans are measured on a subset and scaled
    back (on a surface the spacing goes with 1 / √density)."""
    n = len(pts)
    m = min(n, 50_000)
    sub = pts if m == n else pts[np.random.default_rng(rng_seed).choice(n, m, replace=False)]
    probes = sub[: min(m, 2000)]
    d, _ = cKDTree(sub).query(probes, k=2)
    return float(np.median(d[:, 1]) * np.sqrt(m / n))


def options_against_scan(pts: np.ndarray, o, units: str) -> list[FieldError]:
    """Given radii and tolerances that cannot belong to this scan, named at intake (the fit would fail or
    answer a tube of another size): a pipe radius larger than the whole scan, a pipe, bend or die radius under
    half the samples' spacing (no sample would see its curvature), an ε larger than the scan (every spline fits:
    a straight tube)."""
    errors = []
    extent = scan_extent(pts)
    if o.pipe_radius and o.pipe_radius > extent:
        errors.append(FieldError(loc=("options", "pipe_radius"), msg=(
            f"implausible pipe radius: {o.pipe_radius:g} {units} is larger than the whole scan (its extent is "
            f"{extent:.4g} {units}); check the value and its unit (a diameter, or another unit than {units}?)")))
    radii = [(("options", "pipe_radius"), "pipe radius", o.pipe_radius)] if o.pipe_radius and o.pipe_radius <= extent \
        else []
    radii += [(("options", "bend_radius"), "bend radius", o.bend_radius)] if o.bend_radius else []
    radii += [(("options", "dies", i), "die radius", d) for i, d in enumerate(o.dies or [])]
    spacing = sample_spacing(pts) if radii else 0.0
    for loc, name, r in radii:
        if r < 0.5 * spacing:
            errors.append(FieldError(loc=loc, msg=(
                f"implausible {name}: {r:g} {units} is under half the samples' spacing ({spacing:.4g} {units}): no "
                "fit could see a curvature that tight; check the value and its unit")))
    if o.pipe_radius and 0.5 * spacing <= o.pipe_radius <= extent:
        errors.extend(pipe_radius_against_measured(pts, o.pipe_radius, units))
    if o.tolerance and o.tolerance > extent:
        errors.append(FieldError(loc=("options", "tolerance"), msg=(
            f"implausible tolerance: ε = {o.tolerance:g} {units} is larger than the whole scan (extent "
            f"{extent:.4g} {units}): every spline would fit, a straight tube; ε is a distance from the spine, "
            "typically a tenth of the pipe radius")))
    return errors


# A stated pipe radius this many times the measured one or more (or its inverse or less) is no radius of this scan:
# a diameter gives 2, a unit slip 10 or 25.4. Held fixed, it leaves the fit nothing to follow (the spine stage
# fails, or the tube comes out one straight). The measurement is 0.87 to 1.02 of the radius on synthetic scans of
# 2,000 to 50,000 samples, noise up to 3 % of the radius, 2 % outliers, seen from one side, printed to 1 mm.
PIPE_RADIUS_RATIO = 1.4
# ... or 1 + this many times the scan's noise relative to the measured radius, when more. Where the noise is a large
# part of the radius (a 1 mm tube scanned with 0.1 to 0.2 mm noise: 7 % to 16 % of it) the quadric fits scatter
# and the median of 300 of them lies from 0.64 to 1.45 of the radius; its noise gives the width. On 60 synthetic
# scans (the 24 thin noisy one-sided ones, 36 with clutter, neighbours, sparse) the right radius is then never
# refused (a factor 1.4 refused 3, their ratios 1.50 to 1.57 at noise 14 % to 16 %), and each diameter, half, 10×
# and 25.4× the factor 1.4 refuses still is (a fixed 1.8 let 19 of those 58 diameters through).
NOISE_WIDENING = 4.5
# ... unless this share of the cross-sections shows the stated radius (to 20 %): a scan that holds more than the
# tube (a fixture, a table top) has a median of other curvatures, and the solve takes the tube's samples alone.
# The right radius is shown by 0.38 to 0.94 of them (sparse noisy scans the least), half of it by 0.26 at most (its
# ball of a third of a radius scatters), twice it by 0.08 at most.
SHOWN_SHARE = 0.3
RADIUS_PROBES = 300  # cross-sections measured (the solve's first estimate takes 1,500 of 50,000 samples)
RADIUS_PASSES = 3


def _radius_probes(pts: np.ndarray, rng_seed: int = 0) -> tuple[cKDTree, np.ndarray, np.ndarray]:
    """A tree of at most 50,000 of the samples, those samples, and :data:`RADIUS_PROBES` of them to fit at."""
    rng = np.random.default_rng(rng_seed)
    work = pts if len(pts) <= 50_000 else pts[rng.choice(len(pts), 50_000, replace=False)]
    return cKDTree(work), work, work[rng.choice(len(work), min(RADIUS_PROBES, len(work)), replace=False)]


def measured_pipe_radius(pts: np.ndarray) -> float | None:
    """The pipe radius the samples show (:func:`pipe_radius_measurement`), None when none."""
    measurement = pipe_radius_measurement(pts)
    return None if measurement is None else measurement[0]


def pipe_radius_measurement(pts: np.ndarray) -> tuple[float, float] | None:
    """The pipe radius the samples show and their noise relative to it: the median radius of the larger principal
    curvature of local quadric fits (as the solve's own estimate, §3.1) at a few hundred samples, each fitted in a
    ball of the radius found before (:data:`RADIUS_PASSES` times, from fits over 40 neighbours), and the median
    rms of the last fits over that radius. A ball of a whole radius averages out the noise of sparse scans (2,000
    samples, noise 3 % of the radius: 0.6 of the radius in balls of 2/3 of it, 0.9 in these). None when no fit
    succeeds or the median is no tube's (beyond the scan's extent: mostly flat)."""
    tree, work, probes = _radius_probes(pts)
    fits = local_fit.knn_fit(tree, work, probes, 40)
    good = fits.ok
    extent = scan_extent(pts)
    for _ in range(RADIUS_PASSES + 1):
        if not good.any():
            return None
        radius = float(np.median(1.0 / np.maximum(fits.kmax[good], 1e-300)))
        if not 0 < radius <= extent:
            return None
        fits = local_fit.fit_at(tree, work, probes, radius)
        good = fits.ok & (fits.count >= 10)
    noise = float(np.median(fits.sigma[good])) if good.any() else 0.0
    return radius, noise / radius


def pipe_radius_ratio(relative_noise: float) -> float:
    """The factor between a stated and the measured pipe radius beyond which the stated one is no radius of the
    scan: :data:`PIPE_RADIUS_RATIO`, wider where the noise is a large part of the radius (:data:`NOISE_WIDENING`)."""
    return max(PIPE_RADIUS_RATIO, 1.0 + NOISE_WIDENING * relative_noise)


def shown_share(pts: np.ndarray, pipe_radius: float) -> float:
    """The share of the cross-sections whose curvature, fitted as the solve fits it (a ball of 2/3 of the radius),
    is that of ``pipe_radius`` to 20 %."""
    tree, work, probes = _radius_probes(pts)
    fits = local_fit.fit_at(tree, work, probes, 2.0 / 3.0 * pipe_radius)
    good = fits.ok & (fits.count >= 10)
    return float(np.mean(np.abs(fits.kmax[good] * pipe_radius - 1.0) <= 0.2)) if good.any() else 0.0


def pipe_radius_against_measured(pts: np.ndarray, pipe_radius: float, units: str) -> list[FieldError]:
    """A stated pipe radius :func:`pipe_radius_ratio` times the measured one or more, or as much less, that few
    cross-sections show, named with both values: a diameter typed where the radius is asked is the usual cause."""
    measurement = pipe_radius_measurement(pts)
    if measurement is None:
        return []
    measured, relative_noise = measurement
    limit = pipe_radius_ratio(relative_noise)
    if 1.0 / limit < pipe_radius / measured < limit:
        return []
    if shown_share(pts, pipe_radius) >= SHOWN_SHARE:
        return []
    ratio = pipe_radius / measured
    # a ratio near one unit's size in another's: the scan's coordinates in that unit, read in the request's
    slip = [u for u in UNIT_MM if u != units and abs(np.log(ratio * UNIT_MM[units] / UNIT_MM[u])) < np.log(limit)]
    why = ("a diameter? The radius is half of it." if abs(ratio - 2.0) < 0.3 else
           f"a radius in another unit (the scan's coordinates in {slip[0]}, read as {units}? Set "
           f"options.file_units to {slip[0]!r} for an upload, or units), or of another tube?" if slip
           else "a radius in another unit, or of another tube?")
    return [FieldError(loc=("options", "pipe_radius"), msg=(
        f"pipe radius {pipe_radius:g} {units} is {ratio:.2g} times the radius the scan's cross-sections show "
        f"({measured:.3g} {units}): {why} The fit holds a given radius fixed and cannot follow a tube of another "
        "size; give the outer radius, or leave pipe_radius out to have it measured"))]


# physical bounds of a pipe's outer radius: thinner than a hypodermic tube or wider than a 4 m main is
# no bent tube, but a unit mix-up (metres read as millimetres gives 1000× too small)
RADIUS_MM_PLAUSIBLE = (0.5, 2000.0)
# and of a scan of one tube (its bounding-box diagonal)
EXTENT_MM_PLAUSIBLE = (5.0, 200_000.0)
# millimetres per unit of each unit a scan's coordinates may be in: the request's and micrometres (length_units)
UNIT_MM = MappingProxyType({unit: metres * 1000.0 for unit, metres in SIZES.items()})


def likely_units(mm: float, bounds: tuple[float, float], read_as: str) -> list[str]:
    """The units the coordinates were likely in when a length read as ``read_as`` is ``mm`` in physical terms and
    outside ``bounds``: those that put it inside, the largest factor first (metres and millimetres swapped is
    the usual mix-up: scanners write metres)."""
    lo, hi = bounds
    return sorted((u for u, f in UNIT_MM.items() if u != read_as and lo <= mm * f / UNIT_MM[read_as] <= hi),
                  key=lambda u: -abs(np.log(UNIT_MM[u] / UNIT_MM[read_as])))


def _read_as(units: str, file_units: str | None) -> str:
    return file_units if file_units in UNIT_MM else units  # a CRS's own unit name: judged in the request's


def implausible_pipe_radius(pipe_radius: float, units: str, file_units: str | None = None) -> Diagnostic | None:
    """A warning when the pipe radius, in physical terms, is outside ``RADIUS_MM_PLAUSIBLE``, naming the units
    in which the same number would be plausible (the likely mix-up); None when it is plausible."""
    lo, hi = RADIUS_MM_PLAUSIBLE
    mm = pipe_radius * UNIT_MM[units]
    if lo <= mm <= hi:
        return None
    read_as = _read_as(units, file_units)
    likely = likely_units(mm, RADIUS_MM_PLAUSIBLE, read_as)
    hint = (f"the coordinates are likely in {' or '.join(likely)} but were read as {read_as}" if likely
            else "check the units")
    return Diagnostic(
        code="implausible_pipe_radius",
        message=f"A pipe radius of {pipe_radius:.4g} {units} ({mm:.4g} mm) is implausible for a tube "
        f"(expected {lo:g} mm to {hi / 1000:g} m): {hint}; set options.file_units (uploads) or units.",
        details={"pipe_radius": pipe_radius, "units": units, "pipe_radius_mm": mm, "plausible_mm": [lo, hi],
                 "read_as": read_as, "likely_units": likely})


# A fitted radius under this many millimetres, read in the default unit because nothing stated one, is a capillary's
# (under 3 mm across); the same numbers in inches or centimetres are a common tube's (a 20 mm tube scanned in inches
# reads as 0.79 mm, every length 25.4 times too small, and passes every physical bound)
SMALL_RADIUS_MM = 1.5
# the units such a scan was likely written in: the imperial shop's and the one a metric export's slip gives
SMALL_RADIUS_LIKELY = ("in", "cm")
UNIT_WORDS = {"in": "inches", "cm": "centimetres"}


def assumed_unit_small_radius(pipe_radius: float, request) -> Diagnostic | None:
    """A warning when an uploaded scan that states no unit, with none given (no ``units``, no ``file_units``, no
    radius or nominal in a unit to compare with), was read in the default unit and its fitted radius is a
    capillary's there (:data:`SMALL_RADIUS_MM`): the unit was assumed, and in inches or centimetres the same scan is
    a common tube. Stating the unit (millimetres for a capillary) says which."""
    source, opts = request.source, request.options
    if source is None or source.units.basis != "request" or "units" in request.model_fields_set:
        return None
    if opts.pipe_radius or opts.nominal or opts.nominal_xyz_clr or opts.nominal_csv:
        return None  # a radius or a nominal in the request's unit: checked against the scan on their own
    units = request.units
    mm = pipe_radius * UNIT_MM[units]
    if not RADIUS_MM_PLAUSIBLE[0] <= mm < SMALL_RADIUS_MM:
        return None  # a plausible tube's, or implausible_pipe_radius's
    other = {u: pipe_radius * UNIT_MM[u] for u in SMALL_RADIUS_LIKELY if u != units}
    said = " or ".join(f"{r:.3g} mm if the file is in {UNIT_WORDS[u]}" for u, r in other.items())
    in_mm = "" if units == "mm" else f" ({mm:.3g} mm)"
    return Diagnostic(code="file_units_assumed", message=(
        f"The {source.format.upper()} file states no unit and none was given: its coordinates were read in {units}, "
        f"the default, and the fitted pipe radius is {pipe_radius:.3g} {units}{in_mm}, a capillary's; it is "
        f"{said}, a common tube's (every length scales alike). Set options.file_units to the unit of the file's "
        f"coordinates ('{units}' if it is a capillary)."),
        details={"pipe_radius": pipe_radius, "units": units, "pipe_radius_mm": mm, "basis": "default",
                 "small_radius_mm": SMALL_RADIUS_MM, "pipe_radius_mm_if": other})


# a bend radius (CLR) under the pipe radius is no bend a bender makes (the inner wall would fold); one over
# BEND_RADIUS_MAX_PIPE pipe radii is beyond the fit's own bound (``fit.bounds``: a 1° bend needs no more)
BEND_RADIUS_MAX_PIPE = 200.0
TOLERANCE_MAX_PIPE = 1.0  # ε above the pipe radius merges bends whose arcs bulge less than a radius


def implausible_against_scan(model, opts, units: str, extent: float, file_units: str | None = None) -> list[Diagnostic]:
    """Warnings for radii and tolerances the solve ran with but that do not fit the scan: the pipe radius in
    physical terms (``implausible_pipe_radius``), a given bend radius or die under the pipe radius or beyond
    ``BEND_RADIUS_MAX_PIPE`` pipe radii or the scan's extent, an ε above the pipe radius."""
    out = []
    rp = float(model.pipe_radius)
    pipe = implausible_pipe_radius(rp, units, file_units)
    if pipe:
        out.append(pipe)
    given = ([("options.bend_radius", float(opts.bend_radius))] if opts.bend_radius else []) + \
        [(f"options.dies[{i}]", float(d)) for i, d in enumerate(opts.dies or [])]
    hi = min(BEND_RADIUS_MAX_PIPE * rp, extent)
    for name, r in given:
        if r < rp:
            why = f"under the pipe radius {rp:.4g} {units}: no bender makes it (the inner wall would fold)"
        elif r > hi:
            # a bend whose chord fits in the scan turns at most 2 asin(extent / 2R)
            turn = np.degrees(2 * np.arcsin(min(1.0, extent / (2 * r))))
            why = (f"over {hi:.4g} {units} (the smaller of {BEND_RADIUS_MAX_PIPE:g} pipe radii and the scan's "
                   f"extent): a bend on it turns at most {turn:.2g}° within the scan")
        else:
            continue
        out.append(Diagnostic(code="implausible_bend_radius", message=(
            f"{name} = {r:.4g} {units} is implausible: {why}; check the value (a diameter?) and its unit."),
            details={"field": name, "bend_radius": r, "pipe_radius": rp, "extent": extent, "units": units,
                     "plausible": [rp, hi]}))
    if opts.tolerance and opts.tolerance > TOLERANCE_MAX_PIPE * rp:
        out.append(Diagnostic(code="implausible_tolerance", message=(
            f"options.tolerance ε = {opts.tolerance:.4g} {units} is above the pipe radius ({rp:.4g} {units}): "
            "bends whose arcs bulge less than ε from their chord are merged into straights; the default is "
            "0.08 pipe radii or four times the spine noise."),
            details={"tolerance": float(opts.tolerance), "pipe_radius": rp, "units": units,
                     "plausible": [0.0, TOLERANCE_MAX_PIPE * rp]}))
    return out


def implausible_extent(extent: float, units: str, file_units: str | None = None) -> str | None:
    """A sentence for a failed fit when the scan's size, in physical terms, is outside ``EXTENT_MM_PLAUSIBLE``
    (the likely cause of the failure), naming the likely units; None when the size is plausible."""
    lo, hi = EXTENT_MM_PLAUSIBLE
    mm = extent * UNIT_MM[units]
    if lo <= mm <= hi:
        return None
    read_as = _read_as(units, file_units)
    likely = likely_units(mm, EXTENT_MM_PLAUSIBLE, read_as)
    return (f"the scan spans {extent:.4g} {units} ({mm:.4g} mm), implausible for a tube"
            f"{': its coordinates are likely in ' + ' or '.join(likely) + ', not ' + read_as if likely else ''}; "
            "set options.file_units (uploads) or units")
