"""A field given as points with their values, placed on the rectilinear grid their coordinates make.

FE tools write a field as rows (x, y, z, B_x, B_y[, B_z]) in an order of their own (x or z fastest, by
mesh node); a flat list of values needs that order to be known, rows carry it. Each axis's grid lines are
the distinct coordinates of the rows (values closer than a tolerance are one line, as a tool's rounding
writes them); each row goes to the grid point of its lines. Whatever the row order, the grid and its
values are the same to the last bit.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# coordinates closer than this fraction of the grid's largest extent (its middle half's, doubled) lie on one grid
# line (a tool's rounding, -0 and 1e-17 for 0); farther, a point lies off the lines
LINE_TOLERANCE = 1e-6
# two rows at one grid point are one value given twice when they agree to this (relative to the largest |B|)
SAME_VALUE = 1e-9
# a thinly populated end line farther than this many times the other lines' widest spacing is a mistyped coordinate
FAR_LINE = 100.0
AXES = ("x", "y", "z")


class PointsNotAGrid(ValueError):
    """The rows do not make a complete rectilinear grid; ``row`` is the index of the row to name (or None)."""

    def __init__(self, message: str, row: int | None = None):
        super().__init__(message)
        self.row = row


@dataclass(frozen=True)
class PlacedField:
    """The rows' field on its grid (the rows' units)."""

    x: np.ndarray
    y: np.ndarray
    z: np.ndarray
    bx: np.ndarray  # (nx, ny, nz)
    by: np.ndarray


def _grid_lines(values: np.ndarray, tolerance: float) -> tuple[np.ndarray, np.ndarray]:
    """The distinct lines of one axis and each row's line index. A line's coordinate is the middle of its
    sorted distinct values, so that it does not depend on the rows' order."""
    distinct, inverse = np.unique(values, return_inverse=True)
    starts = np.concatenate([[0], np.flatnonzero(np.diff(distinct) > tolerance) + 1])
    member = np.searchsorted(starts, np.arange(len(distinct)), side="right") - 1
    ends = np.concatenate([starts[1:], [len(distinct)]])
    lines = distinct[(starts + ends - 1) // 2]
    return lines, member[inverse.ravel()]


def _stray_line(name: str, lines: np.ndarray, index: np.ndarray, tolerance: float) -> PointsNotAGrid | None:
    """A line holding few rows next to full ones: rows off a grid line by more than the tolerance (a value
    written with another rounding, or edited). Decided from the counts once, in linear time: a file of many thin
    lines must not cost a pass over the lines per thin line."""
    counts = np.bincount(index, minlength=len(lines))
    if len(lines) < 3:
        return None
    full = int(np.bincount(counts).argmax())
    gaps = np.diff(lines)
    # the other lines' smallest spacing without line k: its two gaps merge into one
    before = np.minimum.accumulate(np.concatenate([[np.inf, np.inf], gaps]))[:len(lines)]  # gaps left of k-1
    after = np.minimum.accumulate(np.concatenate([gaps, [np.inf, np.inf]])[::-1])[::-1][1:]  # gaps right of k+1
    left = np.concatenate([[np.inf], gaps])
    right = np.concatenate([gaps, [np.inf]])
    merged = np.where(np.isfinite(left) & np.isfinite(right), left + right, np.inf)
    spacing = np.minimum(np.minimum(before, after), merged)
    nearest = np.minimum(left, right)
    stray = (counts <= full / 2) & (nearest < 0.25 * spacing)
    if not np.any(stray):
        return None
    thin_first = np.argsort(counts, kind="stable")
    k = int(thin_first[np.argmax(stray[thin_first])])
    neighbour = lines[k - 1] if left[k] <= right[k] else lines[k + 1]
    row = int(np.flatnonzero(index == k)[0])
    return PointsNotAGrid(
        f"{name} = {lines[k]:.10g} lies off the grid line {name} = {neighbour:.10g} by "
        f"{abs(neighbour - lines[k]):.3g} (the tolerance is {tolerance:.3g}); {counts[k]} row(s) give it, "
        f"{full} each of the other lines: the points do not make a rectilinear grid", row)


def _far_line(name: str, lines: np.ndarray, index: np.ndarray) -> PointsNotAGrid | None:
    """A line at an end of the axis, holding few rows, far beyond the others (more than FAR_LINE times their widest
    spacing from its neighbour): a mistyped coordinate or one in another unit, which would otherwise be named as
    the grid points the row is missing from."""
    if len(lines) < 3:
        return None
    counts = np.bincount(index, minlength=len(lines))
    full = int(np.bincount(counts).argmax())
    for k, neighbour, others in ((0, 1, np.diff(lines[1:])), (len(lines) - 1, len(lines) - 2, np.diff(lines[:-1]))):
        gap = abs(lines[k] - lines[neighbour])
        if counts[k] <= full / 2 and gap > FAR_LINE * float(np.max(others)):
            row = int(np.flatnonzero(index == k)[0])
            return PointsNotAGrid(
                f"{name} = {lines[k]:.10g} lies {gap:.3g} beyond the grid line {name} = {lines[neighbour]:.10g}, where "
                f"the other {name} lines are at most {float(np.max(others)):.3g} apart; {counts[k]} row(s) give it, "
                f"{full} each of the other lines: a mistyped coordinate, or one in another unit?", row)
    return None


def place_on_grid(rows: np.ndarray, label=lambda row: f"row {row}") -> PlacedField:
    """Rows (n, 5 or 6) of x, y, z, bx, by[, bz] on their rectilinear grid; raises :class:`PointsNotAGrid`
    naming a row (a point off the grid lines, a point given twice with other values) or a missing grid point.
    ``label(row)`` names another row in a message (a file's line)."""
    coordinates = rows[:, :3]
    # the extent of the rows' middle half, doubled: a few mistyped coordinates (1e12) must not widen the tolerance
    # until every other line merges into one
    low, high = np.percentile(coordinates, [25, 75], axis=0) if len(rows) else (np.zeros(3), np.zeros(3))
    extent = 2.0 * float(np.max(high - low))
    tolerance = LINE_TOLERANCE * max(extent, 1e-300)
    lines, index = [], []
    for axis, name in enumerate(AXES):
        line, member = _grid_lines(coordinates[:, axis], tolerance)
        if len(line) < 2:
            raise PointsNotAGrid(f"every point has {name} = {line[0]:g}: a grid needs at least two {name} lines")
        if len(line) > 400:
            stray = _stray_line(name, line, member, tolerance)
            raise stray or PointsNotAGrid(f"the points lie on {len(line)} distinct {name} values; a grid has at most 400 "
                                          "lines per axis (are they a grid, or the nodes of an FE mesh?)")
        lines.append(line)
        index.append(member)
    for name, line, member in zip(AXES, lines, index):
        stray = _far_line(name, line, member) or _stray_line(name, line, member, tolerance)
        if stray:
            raise stray
    shape = tuple(len(line) for line in lines)
    flat = np.ravel_multi_index(tuple(index), shape)
    order = np.argsort(flat, kind="stable")
    ordered = flat[order]
    first_of = np.concatenate([[True], np.diff(ordered) != 0])
    values = rows[:, 3:]
    scale = max(float(np.max(np.abs(values), initial=0.0)), 1e-300)
    group_first = order[np.maximum.accumulate(np.where(first_of, np.arange(len(order)), 0))]
    differ = np.any(np.abs(values[order] - values[group_first]) > SAME_VALUE * scale, axis=1)
    if np.any(differ):
        # name the later row in the file of the first clashing pair, whatever the rows' order
        pairs = sorted((max(int(a), int(b)), min(int(a), int(b))) for a, b in zip(order[differ], group_first[differ]))
        later, earlier = pairs[0]
        point = ", ".join(f"{v:g}" for v in rows[later, :3])
        raise PointsNotAGrid(f"the point ({point}) is also {label(earlier)}, with another value: which is meant is not "
                             "known", later)
    unique = ordered[first_of]
    if len(unique) != int(np.prod(shape)):
        missing = int(np.flatnonzero(np.isin(np.arange(np.prod(shape)), unique, invert=True))[0])
        i, j, k = np.unravel_index(missing, shape)
        raise PointsNotAGrid(
            f"the grid point ({lines[0][i]:g}, {lines[1][j]:g}, {lines[2][k]:g}) has no row: {len(unique)} distinct "
            f"points for a {shape[0]} x {shape[1]} x {shape[2]} grid of {int(np.prod(shape))} (the rows' x, y and z "
            "lines): the points do not make a complete rectilinear grid")
    grid = np.empty((int(np.prod(shape)), values.shape[1]))
    grid[ordered[first_of]] = values[order[first_of]]
    grid = grid.reshape(*shape, values.shape[1])
    return PlacedField(lines[0], lines[1], lines[2], grid[..., 0], grid[..., 1])  # B_z does not enter U
