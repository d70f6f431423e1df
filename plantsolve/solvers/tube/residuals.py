"""Distances of samples to their assigned segment's line or circle (unbounded) and the gradients with respect to
that segment's geometry, for the least-squares rounds (``fit``).

A segment's geometry is a row of 7 numbers: lines [point, unit tangent, 0], arcs [centre, unit axis, radius]
(``fit.geometry_batch``). Every sample carries its segment's row, so one pass of array operations covers all
samples whatever their segment: a loop over the segments costs a dozen array operations per segment, which on
a few thousand samples spread over 17 segments is most of the time of an evaluation.
"""

from __future__ import annotations

import numpy as np

BLOCK = 65_536  # samples per pass: the per-sample temporaries of a block stay in the processor's cache


class Distances:
    """Distances of samples ``q`` (N, 3) to the lines or circles ``gs`` (N, 7), one row per sample, ``arc`` (N,)
    telling which; the intermediate terms are kept for :meth:`gradient`."""

    def __init__(self, q: np.ndarray, gs: np.ndarray, arc: np.ndarray):
        self.arc = arc
        a = gs[:, 3:6]
        self.w = q - gs[:, :3]  # from the line point / circle centre
        self.s = np.einsum("nk,nk->n", self.w, a)  # along the tangent / axis
        self.perp = self.w - self.s[:, None] * a
        self.rho = np.sqrt(np.einsum("nk,nk->n", self.perp, self.perp))  # from the line / axis
        self.radial = self.rho - gs[:, 6]  # lines have radius 0
        # a line's distance is rho; a circle's the hypotenuse of the radial and axial offsets
        self.distance = np.where(arc, np.hypot(self.radial, self.s), self.rho)
        self.axis = a

    def gradient(self) -> np.ndarray:
        """d distance / d geometry (N, 7). Lines: -e for the point, -s e for the tangent (e the unit offset from
        the line); circles: -(radial e + s a) / d for the centre, s (w - radial e) / d for the axis, -radial / d
        for the radius."""
        arc, s, w = self.arc, self.s[:, None], self.w
        e = self.perp / np.maximum(self.rho, 1e-300)[:, None]
        inv = (1.0 / np.maximum(self.distance, 1e-300))[:, None]
        radial = self.radial[:, None]
        se = s * e
        grad = np.empty((len(w), 7))
        grad[:, :3] = np.where(arc[:, None], -(radial * e + s * self.axis) * inv, -e)
        grad[:, 3:6] = np.where(arc[:, None], (s * w - radial * se) * inv, -se)
        grad[:, 6] = np.where(arc, -self.radial * inv[:, 0], 0.0)
        return grad


def blocks(seg: np.ndarray, block: int = BLOCK) -> list[tuple[slice, list[tuple[int, slice]]]]:
    """Blocks of at most ``block`` samples of a segment array sorted by segment, each with its runs of one segment
    (segment, slice within the block)."""
    out = []
    for a in range(0, len(seg), block):
        sb = seg[a:a + block]
        ks, starts = np.unique(sb, return_index=True)
        ends = np.r_[starts[1:], len(sb)]
        out.append((slice(a, a + len(sb)), [(int(k), slice(int(i), int(j))) for k, i, j in zip(ks, starts, ends)]))
    return out
