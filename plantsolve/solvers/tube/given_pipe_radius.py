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

from dataclasses import dataclass, field

import numpy as np
from scipy.special import fdtrc

from plantsolve.schemas.common import Diagnostic
from plantsolve.solvers.base import SolverError
from plantsolve.solvers.tube.model import TubeModel, build_spine
from plantsolve.solvers.tube.validation import measured_pipe_radius

# a given radius this far from the straights' circles (as a ratio) is no radius of this tube; the right radius
# is within 1 % on the synthetic scans of the tests (noise to 3 % of the radius, one side or all round)
DISAGREEMENT = 0.08
MIN_SAMPLES = 40  # on a straight, for its circle
MAX_SAMPLES = 20_000  # of a straight, evenly taken: the radius to 1e-3 needs no more, and a large scan's cost stays
MIN_ARC_DEG = 90.0  # the samples of a straight must span this much of its circumference, about either circle's centre
# ... and the given radius must fit them significantly worse than a free one: the F statistic of the radius held
# (one constraint a straight) at p < 0.001. A free circle on a narrow strip of each cross-section (a scan seen
# through a slot, ±11°) misses the radius several times over, but the given one fits it as well (F ≈ 0.1 on a 23°
# arc at 5 % noise; a radius 1.15 or 0.92 times the true one on a 150° arc at 3 % noise gives F ≈ 560 and 260).
SIGNIFICANCE = 1e-3


@dataclass
class StraightCircles:
    """The straights' cross-sections: each one's free circle (radius and residual sum of squares) and the residual
    sum of squares of a circle of the given radius, its centre free, with the samples on each."""

    radii: list[float] = field(default_factory=list)
    rss_free: list[float] = field(default_factory=list)
    rss_given: list[float] = field(default_factory=list)
    samples: list[int] = field(default_factory=list)

    def radius(self) -> float | None:
        """The free circles' median radius weighted by the samples on each (None: no straight measured)."""
        if not self.radii:
            return None
        order = np.argsort(self.radii)
        cumulative = np.cumsum(np.asarray(self.samples)[order])
        return float(np.asarray(self.radii)[order][np.searchsorted(cumulative, cumulative[-1] / 2)])

    def given_fits_worse(self) -> bool:
        """Whether the given radius fits the cross-sections significantly worse than free radii (F-test of one
        constraint a straight, at :data:`SIGNIFICANCE`)."""
        k, n = len(self.radii), sum(self.samples)
        free, given = sum(self.rss_free), sum(self.rss_given)
        if k == 0 or n <= 3 * k:
            return False
        if free <= 0:
            return given > 0
        statistic = (given - free) / k / (free / (n - 3 * k))
        return bool(fdtrc(k, n - 3 * k, statistic) < SIGNIFICANCE)  # the F distribution's tail beyond it


def _gauss_newton(q: np.ndarray, c: np.ndarray, r: float | None) -> tuple[np.ndarray, float, float] | None:
    """The circle nearest ``q`` in geometric distance, from centre ``c``, of radius ``r`` held (None: free): its
    centre, radius and residual sum of squares; None when it degenerates."""
    free = r is None
    r = float(np.linalg.norm(q - c, axis=1).mean()) if free else r
    for _ in range(15):
        d = q - c
        rho = np.linalg.norm(d, axis=1)
        if not (rho > 0).all():
            return None
        J = -d / rho[:, None]
        if free:
            J = np.column_stack([J, -np.ones(len(q))])
        step, *_ = np.linalg.lstsq(J, -(rho - r), rcond=None)
        c = c + step[:2]
        if free:
            r += float(step[2])
    res = np.linalg.norm(q - c, axis=1) - r
    return (c, r, float(res @ res)) if r > 0 and np.isfinite(res).all() else None


def _free_circle(q: np.ndarray) -> tuple[np.ndarray, float, float] | None:
    """The circle through 2-D points ``q``, its centre, radius and residual sum of squares (algebraic fit,
    refined in the geometric distance so that noise on a half circle does not shrink it)."""
    A = np.column_stack([2 * q, np.ones(len(q))])
    sol, *_ = np.linalg.lstsq(A, (q * q).sum(1), rcond=None)
    if not sol[2] + sol[:2] @ sol[:2] > 0:
        return None
    return _gauss_newton(q, sol[:2], None)


def _given_circle(q: np.ndarray, free_centre: np.ndarray, given: float) -> tuple[np.ndarray, float, float] | None:
    """The circle of radius ``given`` nearest ``q``, its centre free: started ``given`` from the samples' centroid
    toward the free circle's centre (the side the arc bends to)."""
    m = q.mean(0)
    toward = free_centre - m
    norm = float(np.linalg.norm(toward))
    return _gauss_newton(q, m + toward / norm * given if norm > 0 else free_centre, given)


def _covered_deg(q: np.ndarray, centre: np.ndarray) -> float:
    """How much of the circumference about ``centre`` the samples ``q`` span, in degrees."""
    angle = np.sort(np.arctan2(q[:, 1] - centre[1], q[:, 0] - centre[0]))
    return float(np.degrees(2 * np.pi - max(np.diff(angle).max(initial=0), 2 * np.pi - angle[-1] + angle[0])))


def straight_circles(model: TubeModel, pts: np.ndarray, segment: np.ndarray, keep: np.ndarray,
                     given: float) -> StraightCircles:
    """The circles across the fitted straights of the inliers around them (:class:`StraightCircles`): of the
    straights holding :data:`MIN_SAMPLES` or more around :data:`MIN_ARC_DEG` of their circumference, measured
    about the free circle's centre and the given one's (the centroid of a narrow strip sees it from anywhere)."""
    sp = build_spine(model)
    circles = StraightCircles()
    for k in np.flatnonzero(sp.kind == 0):
        on = np.flatnonzero(keep & (segment == k))
        if len(on) < MIN_SAMPLES:
            continue
        p = pts[on[:: len(on) // MAX_SAMPLES + 1]] - sp.start[k]
        axis = sp.tangent[k] / np.linalg.norm(sp.tangent[k])
        u = np.cross(axis, [1.0, 0, 0] if abs(axis[0]) < 0.9 else [0, 1.0, 0])
        u /= np.linalg.norm(u)
        q = np.column_stack([p @ u, p @ np.cross(axis, u)])
        free = _free_circle(q)
        held = _given_circle(q, free[0], given) if free is not None else None
        if free is None or held is None or min(_covered_deg(q, free[0]), _covered_deg(q, held[0])) < MIN_ARC_DEG:
            continue
        circles.radii.append(free[1])
        circles.rss_free.append(free[2])
        circles.rss_given.append(held[2])
        circles.samples.append(len(q))
    return circles


def given_radius_warning(model: TubeModel, pts: np.ndarray, segment: np.ndarray, keep: np.ndarray,
                         units: str) -> Diagnostic | None:
    """``pipe_radius_disagrees`` when the given (held) pipe radius is more than :data:`DISAGREEMENT` off the
    radius the straights show and fits their samples significantly worse, naming both; None otherwise."""
    given = float(model.pipe_radius)
    circles = straight_circles(model, pts, segment, keep, given)
    shown = circles.radius()
    if shown is None or abs(given / shown - 1.0) <= DISAGREEMENT or not circles.given_fits_worse():
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
