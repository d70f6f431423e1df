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

import numpy as np

from plantsolve.schemas.tube import LraRow
from plantsolve.solvers.tube.model import TubeModel

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
        order = ("length", "rotation", "angle", "bend_radius")
        row.undetermined = [f for f in order if f in row.undetermined]
        row.determined = not row.undetermined
