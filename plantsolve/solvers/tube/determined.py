"""What the samples determine of each LRA row, and what they only bound.

An end straight's length is where the samples end: the tube is at least that long, and when the samples reach
its cut end it may still end up to about one sample spacing (along the tube) beyond the last of them. So the two
end rows carry ``length_bound = 'lower'``, that spacing as ``sigma_length`` and ``length`` among their
``undetermined`` fields. An end straight that holds almost no samples means they stop inside or just after the
bend before it: that bend is seen from one side only, and its angle is a lower bound too. A bend radius the
reconstruction flagged (``bend_radius_undetermined``) is listed as well. The inspection gives no verdict on such
a field unless its deviation is proven anyway (``tolerances``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from plantsolve.schemas.common import Diagnostic
from plantsolve.schemas.tube import LraRow, TubeResult
from plantsolve.solvers.tube.model import TubeModel, build_spine, sample_centreline

FIELD_ORDER = ("length", "rotation", "angle", "bend_radius")
# an end straight with fewer inlier samples than this does not show where the bend before it ends
MIN_END_SAMPLES = 10


def end_spacing(model: TubeModel, seg: np.ndarray, end: int) -> tuple[float, int]:
    """The samples' spacing along the end straight ``end`` (0 first, 1 last) and how many it holds: its length
    over its sample count (uniform samples leave a gap of that mean beyond the last one before the cut end)."""
    k = 0 if end == 0 else 2 * model.n_bends
    count = int(np.count_nonzero(seg == k))
    length = float(model.lengths[0 if end == 0 else -1])
    return (length / count if count else length), count


def mark_rows(rows: list[LraRow], model: TubeModel, seg_inlier: np.ndarray, loose_radii: list[int]) -> None:
    """Set ``determined``, ``undetermined``, the bounds and the end straights' sigma on the result's ``rows``
    (in the model's walking direction); ``seg_inlier`` holds the segment of each inlier sample."""
    n = model.n_bends
    for row in rows:
        row.undetermined = []
    spacing = [end_spacing(model, seg_inlier, e) for e in (0, 1)]
    if n == 0:  # one straight holds both ends
        rows[0].sigma_length = float(np.hypot(spacing[0][0], spacing[1][0]))
    else:
        rows[0].sigma_length, rows[-1].sigma_length = spacing[0][0], spacing[1][0]
    for i in {0, n}:
        rows[i].length_bound = "lower"
        rows[i].undetermined.append("length")
    if n:
        for end, (_, count) in enumerate(spacing):
            if count < MIN_END_SAMPLES:
                bend = 0 if end == 0 else n - 1
                rows[bend].angle_bound = "lower"
                rows[bend].undetermined.append("angle")
    for k in loose_radii:
        rows[k].undetermined.append("bend_radius")
    for row in rows:
        row.undetermined = [f for f in FIELD_ORDER if f in row.undetermined]
        row.determined = not row.undetermined


# A stretch of the fitted centreline with no inlier sample is a scan gap when it is longer than both of these: ten
# pipe radii (five diameters; a single view that misses the far side still projects onto every stretch), and thirty
# times the samples' mean spacing along the centreline (n samples spread at random along a length L leave no gap
# over k L / n but with odds about n e^-k: 1e-6 at k = 30 for ten million samples, so a sparse scan raises none)
GAP_RADII = 10.0
GAP_SPACINGS = 30.0
# the centreline's sampling step, in pipe radii (a gap's ends are known to within it)
GAP_STEP_RADII = 0.25
# the two sides of a gap line up as one tube's when one bend (or none) can join them: their axes pass within this
# many pipe radii of each other, meeting ahead of both sides
ALIGN_RADII = 0.5
# at most this many samples are projected (a stride through all, its inliers kept; the spacing is that of those)
GAP_MAX_SAMPLES = 30_000


@dataclass
class ScanGap:
    start: float  # arc length along the fitted centreline where the samples stop, request units
    end: float  # where they start again
    fields: dict[int, list[str]]  # LRA row (0-based) -> its fields the unsampled stretch lies on
    offset: float  # the closest approach of the two sides' axes (0 when they meet), request units
    misaligned: str | None  # why no one bend joins the sides (None when one can): the fit's bends there are invented

    @property
    def two_pieces(self) -> bool:
        return self.misaligned is not None

    @property
    def length(self) -> float:
        return self.end - self.start


def scan_gaps(model: TubeModel, pts: np.ndarray, inlier: np.ndarray) -> list[ScanGap]:
    """The stretches of the fitted centreline no inlier sample lies beside (nearest centreline point), longer than
    :data:`GAP_RADII` pipe radii and :data:`GAP_SPACINGS` mean sample spacings, in order along the tube."""
    idx = np.arange(0, len(pts), int(np.ceil(len(pts) / GAP_MAX_SAMPLES)))  # (no index array of a large scan's size)
    idx = idx[inlier[idx]]
    if len(idx) < 2:
        return []
    r = model.pipe_radius
    c, tangent = sample_centreline(model, GAP_STEP_RADII * r)
    along = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(c, axis=0), axis=1))])
    covered = np.unique(cKDTree(c).query(pts[idx])[1])
    spans = np.diff(along[covered])
    limit = max(GAP_RADII * r, GAP_SPACINGS * along[-1] / len(idx))
    sp = build_spine(model)
    seg_end = np.cumsum(sp.length)
    out = []
    for g in np.flatnonzero(spans > limit):
        a, b = covered[g], covered[g + 1]
        fields: dict[int, list[str]] = {}
        for k in np.flatnonzero((seg_end - sp.length < along[b]) & (seg_end > along[a]) & (sp.length > 0)):
            fields.setdefault(int(k) // 2, []).extend(["angle", "bend_radius"] if k % 2 else ["length"])
        offset, misaligned = one_bend_joins(c[a], tangent[a], c[b], tangent[b], ALIGN_RADII * r)
        out.append(ScanGap(float(along[a]), float(along[b]), fields, offset, misaligned))
    return out


def one_bend_joins(pa: np.ndarray, ta: np.ndarray, pb: np.ndarray, tb: np.ndarray,
                   tol: float) -> tuple[float, str | None]:
    """Whether one bend (or a straight) can lead from the side ending at ``pa`` heading ``ta`` to the side starting
    at ``pb`` heading ``tb``: a bend lies in one plane, so the two axes must meet (within ``tol``) at a corner ahead
    of the first side and behind the second; parallel axes must be one line (a straight) or point back (a U-bend).
    Returns the axes' closest approach and, when no one bend joins them, why."""
    w = pb - pa
    n = np.cross(ta, tb)
    if np.linalg.norm(n) < np.sin(np.radians(1.0)):
        if ta @ tb < 0:  # a U-bend turns back beside the first side
            return 0.0, None
        offset = float(np.linalg.norm(w - (w @ ta) * ta))
        if offset > tol:
            return offset, "the two sides run parallel, side by side"
        return offset, None if w @ ta > 0 else "the second side starts behind the first"
    offset = float(abs(w @ n) / np.linalg.norm(n))
    if offset > tol:
        return offset, "the two sides' axes do not meet"
    # the corner: pa + s ta = pb + u tb (least squares in s, u)
    (s, u), *_ = np.linalg.lstsq(np.column_stack([ta, -tb]), w, rcond=None)
    return offset, None if s >= -tol and u <= tol else "the two sides' axes meet behind one of them"


def gap_fields(gaps: list[ScanGap]) -> dict[int, list[str]]:
    """The fields (LRA row, 0-based -> names) any of ``gaps`` lies on."""
    out: dict[int, list[str]] = {}
    for g in gaps:
        for k, fields in g.fields.items():
            out[k] = [f for f in FIELD_ORDER if f in out.get(k, ()) or f in fields]
    return out


def report_scan_gaps(result: TubeResult, gaps: list[ScanGap], units: str) -> None:
    """The warning ``scan_gap`` (first on the list: what the rows describe is in doubt) naming each unsampled
    stretch, where it is, how long and the rows it lies on, which are marked not determined (so an inspection gives
    them no verdict). Where the sides do not line up as one tube's the message and the summary say the scan may
    hold two pieces, and every field of the rows bridging them is not determined (the bends there are invented)."""
    if not gaps:
        return
    rows = result.lra
    for g in gaps:
        for k, fields in g.fields.items():
            extra = FIELD_ORDER if g.two_pieces else fields
            rows[k].undetermined = [f for f in FIELD_ORDER if f in rows[k].undetermined or f in extra]
            rows[k].determined = False
    touched = sorted({k for g in gaps for k in g.fields})
    pieces = [g for g in gaps if g.two_pieces]
    said = "; ".join(
        f"from {g.start:.4g} to {g.end:.4g} {units} along the centreline ({g.length:.4g} {units}, "
        f"{g.length / (2 * result.pipe_radius):.3g} pipe diameters; "
        f"rows {', '.join(str(k + 1) for k in sorted(g.fields))})"
        + (f", where {g.misaligned} (their axes' closest approach {g.offset:.3g} {units}): no single bend joins them"
           if g.two_pieces else "") for g in gaps)
    verdict = ("The scan may hold two pieces: the fit joins them with bends no sample shows" if pieces
               else "It may hold two tubes, or one tube with a stretch the scanner did not see")
    result.report.warnings.insert(0, Diagnostic(
        code="scan_gap",
        message=f"No samples lie on the fitted tube {said}. {verdict}; LRA row(s) "
        f"{', '.join(str(k + 1) for k in touched)} are not determined. Scan the gap, or solve each piece alone.",
        details={"gaps": [{"start": g.start, "end": g.end, "length": g.length,
                           "rows": [k + 1 for k in sorted(g.fields)], "two_pieces": g.two_pieces,
                           "axes_offset": g.offset, "why_two_pieces": g.misaligned}
                          for g in gaps],
                 "two_pieces": bool(pieces), "rows": [k + 1 for k in touched], "gap_radii": GAP_RADII,
                 "gap_spacings": GAP_SPACINGS, "units": units}))
    if pieces:
        result.report.message = f"{result.report.message.rstrip('.')}; the scan may hold two pieces (scan_gap)."
    result.report.status = "warning"
