"""Whether the samples hold the reconstructed number of bends: said when they do not, never given as if known.

The surface fit of the right arc-line tube leaves residuals that are noise: along the tube, the mean residual of
the samples over two pipe radii of centreline is within a few standard errors of zero. A bend of a few degrees
the fit left out (pruned as not worth its parameters, or never found by the spline) bends the samples away from
the fitted straight, and a bend fitted in the wrong place leaves the arc's samples off its surface: the mean
residual of those windows is then tens of standard errors off (bench small_bends: 7 true bends reconstructed as
4, z 28; right bend counts up to about 3: :func:`off_windows`). The other way round, a bend whose angle is within
a few standard deviations of zero is one the samples do not tell from none (:func:`weak_bends`). Either gives the
warning ``bend_count_uncertain`` naming the other count, and the LRA rows concerned are not determined.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from plantsolve.schemas.common import Diagnostic
from plantsolve.schemas.tube import TubeResult
from plantsolve.solvers.tube.model import TubeModel, sample_centreline

# the window along the centreline, in pipe radii, and the centreline's sampling step in it
WINDOW_RADII = 2.0
STEP_RADII = 0.25
# windows with fewer samples give no stable mean
MIN_WINDOW_SAMPLES = 20
# |mean| / standard error above which a window is off the fit: the right tubes of the bench stay under 5.6 over
# their 50-200 windows (b2b_coplanar 4.8 and 5.6, the rest under 3.7), the wrong bend counts from 10.2 to 44
Z_LIMIT = 8.0
# the relative step of a float32 coordinate (2^-23: 1.2e-4 mm at 1000 mm), under which a residual is rounding
COORDINATE_STEP = 2.0 ** -23
# at most this many samples are used (a stride through the inliers): the statistic is for the pattern, and
# the tree's query on tens of millions of samples would cost more than the fit
MAX_SAMPLES = 30_000


@dataclass
class OffWindow:
    start: float  # arc length along the centreline where the window starts, request units
    end: float
    z: float  # |mean residual| / its standard error
    mean: float  # mean residual, request units
    fields: dict[int, list[str]]  # LRA row (0-based) -> its fields the window's samples lie on


def centred_size(pts: np.ndarray) -> float:
    """The largest distance of a coordinate from the samples' centre (per axis): the scan's size, the same
    wherever the scan is placed."""
    return float(max(np.abs(pts[:, k] - pts[:, k].mean()).max() for k in range(3)))


def off_windows(model: TubeModel, pts: np.ndarray, residuals: np.ndarray, segment: np.ndarray,
                inlier: np.ndarray) -> list[OffWindow]:
    """The windows of the centreline whose inlier samples' mean residual is more than :data:`Z_LIMIT` standard
    errors off zero, worst first (the standard error from the median absolute deviation of all inliers)."""
    idx = np.flatnonzero(inlier)
    if len(idx) > MAX_SAMPLES:
        idx = idx[:: int(np.ceil(len(idx) / MAX_SAMPLES))]
    if len(idx) < MIN_WINDOW_SAMPLES:
        return []
    r = residuals[idx]
    # no residual is finer than the float32 step of the scan's size (STL and PLY store float32); a noise-free
    # scan's spread is that rounding, or float64's, and means of 1e-12 mm came out hundreds of standard errors
    # off. The size is taken about the samples' centre: where the scan sits (site coordinates) changes nothing.
    s = max(1.4826 * float(np.median(np.abs(r - np.median(r)))), COORDINATE_STEP * centred_size(pts[idx]))
    if not s > 0:
        return []
    step = STEP_RADII * model.pipe_radius
    c, _ = sample_centreline(model, step)
    along = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(c, axis=0), axis=1))])
    _, j = cKDTree(c).query(pts[idx])
    per = int(round(WINDOW_RADII / STEP_RADII))
    win = j // per
    out = []
    for w in np.unique(win):
        on = win == w
        n = int(on.sum())
        if n < MIN_WINDOW_SAMPLES:
            continue
        mean = float(r[on].mean())
        z = abs(mean) / (s / np.sqrt(n))
        if z > Z_LIMIT:
            fields: dict[int, list[str]] = {}
            for k in np.unique(segment[idx[on]]).tolist():  # even: straight k / 2, odd: bend (k - 1) / 2
                fields.setdefault(k // 2, []).extend(["angle", "bend_radius"] if k % 2 else ["length"])
            a, b = int(w * per), min(int((w + 1) * per), len(along) - 1)
            out.append(OffWindow(float(along[a]), float(along[b]), float(z), mean, fields))
    return sorted(out, key=lambda o: -o.z)




# a bend whose angle is within this many standard deviations of zero is one the samples do not tell from none
ANGLE_Z_LIMIT = 3.0


def weak_bends(result: TubeResult) -> list[int]:
    """Bends (0-based) whose angle the samples do not tell from zero: under :data:`ANGLE_Z_LIMIT` standard
    deviations, or with no standard deviation at all (no sample moves with it: a bend the fit put past the last
    sample). Bench small_bends: a 44° bend split into 28 ± 16° and 16 ± 16°; a 6.8° bend at the end of the tube
    with no sample beyond it (8 bends for 7)."""
    return [k for k, row in enumerate(result.lra[:-1]) if row.sigma_angle is not None and row.angle > 0
            and (row.sigma_angle == 0 or row.angle < ANGLE_Z_LIMIT * row.sigma_angle)]


FIELD_ORDER = ("length", "rotation", "angle", "bend_radius")


def _undetermine(row, fields) -> None:
    row.undetermined = [f for f in FIELD_ORDER if f in row.undetermined or f in fields]
    row.determined = False


def report_bend_count(result: TubeResult, windows: list[OffWindow], weak: list[int], units: str) -> None:
    """The warning ``bend_count_uncertain`` (first on the list: the count itself is in doubt) naming the windows
    the fit runs off the samples in (a bend missing there: one bend more may be the tube) and the bends the samples
    do not tell from none (one bend fewer may be), with the rows they touch marked not determined (so an inspection
    gives them no verdict)."""
    if not windows and not weak:
        return
    rows, n = result.lra, len(result.lra) - 1
    for w in windows:
        for k, fields in w.fields.items():
            _undetermine(rows[k], fields)
    for k in weak:
        _undetermine(rows[k], ("angle", "bend_radius"))
    touched = sorted({k for w in windows for k in w.fields} | set(weak))
    said, alternatives = [], []
    if windows:
        worst = windows[0]
        alternatives.append(n + 1)
        said.append(f"the fitted tube runs systematically off the samples between {worst.start:.4g} and "
                    f"{worst.end:.4g} {units} along the centreline (mean residual {worst.mean:.3g} {units}, "
                    f"{worst.z:.0f} standard errors; {len(windows)} such window(s)): a bend may be missing there")
    if weak:
        alternatives.append(n - 1)
        said.append(f"the angle of bend(s) {', '.join(str(k + 1) for k in weak)} is within "
                    f"{ANGLE_Z_LIMIT:g} standard deviations of zero: the samples do not tell it from no bend")
    result.report.warnings.insert(0, Diagnostic(
        code="bend_count_uncertain",
        message=f"{n} bends reconstructed, but {'; and '.join(said)}. The tube may have "
        f"{' or '.join(f'at least {a}' if a > n else str(a) for a in alternatives)} bends; LRA row(s) "
        f"{', '.join(str(k + 1) for k in touched)} "
        "are not determined.",
        details={"bends": n, "alternative_counts": alternatives,
                 "windows": [{"start": w.start, "end": w.end, "z": w.z, "mean_residual": w.mean,
                              "rows": [k + 1 for k in sorted(w.fields)]} for w in windows], "z_limit": Z_LIMIT,
                 "weak_bends": [{"bend": k + 1, "angle": rows[k].angle, "sigma_angle": rows[k].sigma_angle}
                                for k in weak], "angle_z_limit": ANGLE_Z_LIMIT,
                 "rows": [k + 1 for k in touched]}))
    result.report.status = "warning"
