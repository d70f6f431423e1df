"""A given pipe radius against the radius the samples show about the fitted straights.

A given ``pipe_radius`` is held fixed in every fit, so the result repeats it whatever the samples say; the intake
refuses one 1.4 times the local curvature fits' radius or more (``validation.pipe_radius_against_measured``), which
scatter too widely on noisy scans for a closer test. After the fit the straights' axes are known, and the samples
around each straight lie on a circle in the plane across it: a circle fitted there, its radius free, measures the
tube's radius to a fraction of a percent on a scan of a few thousand samples (seen from all sides or from one), so
a given radius 8 % off is plain. The fitted axis itself leans on the held radius only by a fraction of the
difference (a one-sided scan's axis moves toward or away from the samples, which a circle with its centre free
does not care about)."""

from __future__ import annotations

import numpy as np

from plantsolve.schemas.common import Diagnostic
from plantsolve.solvers.base import SolverError
from plantsolve.solvers.tube.model import TubeModel, build_spine
from plantsolve.solvers.tube.validation import measured_pipe_radius

# a given radius this far from the straights' circles (as a ratio) is no radius of this tube; the right radius
# is within 1 % on the synthetic scans of the tests (noise to 3 % of the radius, one side or all round)
DISAGREEMENT = 0.08
MIN_SAMPLES = 40  # on a straight, for its circle
MAX_SAMPLES = 20_000  # of a straight, evenly taken: the radius to 1e-3 needs no more, and a large scan's cost stays
MIN_ARC_DEG = 90.0  # the samples of a straight must span this much of its circumference


def _circle_radius(q: np.ndarray) -> float | None:
    """The radius of the circle through 2-D points ``q`` (algebraic fit, refined by a few Gauss–Newton steps of
    the geometric distance so that noise on a half circle does not shrink it)."""
    A = np.column_stack([2 * q, np.ones(len(q))])
    sol, *_ = np.linalg.lstsq(A, (q * q).sum(1), rcond=None)
    c, r2 = sol[:2], sol[2] + sol[:2] @ sol[:2]
    if not r2 > 0:
        return None
    r = float(np.sqrt(r2))
    for _ in range(10):
        d = q - c
        rho = np.linalg.norm(d, axis=1)
        if not (rho > 0).all():
            return None
        J = np.column_stack([-d / rho[:, None], -np.ones(len(q))])
        step, *_ = np.linalg.lstsq(J, -(rho - r), rcond=None)
        c, r = c + step[:2], r + float(step[2])
    return r if r > 0 else None


def straights_radius(model: TubeModel, pts: np.ndarray, segment: np.ndarray, keep: np.ndarray) -> float | None:
    """The radius of the tube the inliers around the fitted straights show: each straight's circle across its
    axis, their median weighted by the samples on each; None when no straight holds enough samples around
    enough of its circumference."""
    sp = build_spine(model)
    radii, weights = [], []
    for k in np.flatnonzero(sp.kind == 0):
        on = np.flatnonzero(keep & (segment == k))
        if len(on) < MIN_SAMPLES:
            continue
        p = pts[on[:: len(on) // MAX_SAMPLES + 1]] - sp.start[k]
        axis = sp.tangent[k] / np.linalg.norm(sp.tangent[k])
        u = np.cross(axis, [1.0, 0, 0] if abs(axis[0]) < 0.9 else [0, 1.0, 0])
        u /= np.linalg.norm(u)
        q = np.column_stack([p @ u, p @ np.cross(axis, u)])
        angle = np.sort(np.arctan2(q[:, 1] - q[:, 1].mean(), q[:, 0] - q[:, 0].mean()))
        covered = 2 * np.pi - max(np.diff(angle).max(initial=0), 2 * np.pi - angle[-1] + angle[0])
        if np.degrees(covered) < MIN_ARC_DEG:
            continue
        r = _circle_radius(q)
        if r is not None:
            radii.append(r)
            weights.append(len(q))
    if not radii:
        return None
    order = np.argsort(radii)
    cumulative = np.cumsum(np.asarray(weights)[order])
    return float(np.asarray(radii)[order][np.searchsorted(cumulative, cumulative[-1] / 2)])


def given_radius_warning(model: TubeModel, pts: np.ndarray, segment: np.ndarray, keep: np.ndarray,
                         units: str) -> Diagnostic | None:
    """``pipe_radius_disagrees`` when the given (held) pipe radius is more than :data:`DISAGREEMENT` off the
    radius the straights show, naming both; None otherwise."""
    shown = straights_radius(model, pts, segment, keep)
    given = float(model.pipe_radius)
    if shown is None or abs(given / shown - 1.0) <= DISAGREEMENT:
        return None
    ratio = given / shown
    why = "a diameter? The radius is half of it" if abs(ratio - 2.0) < 0.3 else \
        "the outer radius of another tube size, an inner radius, or a nominal size?"
    return Diagnostic(code="pipe_radius_disagrees", message=(
        f"options.pipe_radius = {given:.4g} {units} is {ratio:.3g} times the radius the samples show around the "
        f"fitted straights ({shown:.4g} {units}): {why}. The fit held the given radius, so the centreline, the "
        "bend radii and the lengths were fitted to a tube of another size; leave pipe_radius out to have it "
        "measured, or give the outer radius."),
        details={"pipe_radius": given, "measured_pipe_radius": shown, "ratio": ratio, "units": units,
                 "plausible": [shown * (1 - DISAGREEMENT), shown * (1 + DISAGREEMENT)]})


def with_given_radius_hint(exc: SolverError, given: float | None, pts: np.ndarray, units: str) -> SolverError:
    """A stage after the local fits failed while a given pipe radius was held (the spine of a tube of another
    size collapses, or finds too few samples on its surface): the error names the option and the radius the
    local fits show, the likely cause ("the spine point cloud collapsed to a point" alone named neither)."""
    if not given:
        return exc
    shown = measured_pipe_radius(pts)
    about = f"; the samples' cross-sections show about {shown:.3g} {units}" if shown else ""
    return SolverError(exc.stage, (
        f"{exc.message}. options.pipe_radius = {given:g} {units} was held in every fit{about}: if it is not this "
        "tube's outer radius, leave pipe_radius out to have it measured"),
        {**exc.details, "pipe_radius": given, "measured_pipe_radius": shown, "units": units})
