"""A point far off its own speed line: one pressure typed ten times too large, or a flow with a digit dropped. The
floor of ``data_not_decreasing_concave`` says a line cannot be fitted well but not where the culprit lies, and a flow
divided by ten can even leave the line decreasing and concave (its pressure is the line's highest, now at the smallest
flow). Each point is held against a quadratic fitted through the rest of its line: a point many times further off than
the rest lie from that curve, and by more than half the line's typical pressure (and flow), is named with its values
as given and its file row, so that the user finds the typo."""

from __future__ import annotations

import numpy as np

from plantsolve.schemas.common import Diagnostic
from plantsolve.schemas.perfmap import PerfmapRequest
from plantsolve.solvers.perfmap.setting_lines import Setting

MIN_POINTS = 5  # a quadratic through the other four or more points: fewer say nothing about the one left out
# of the line's median pressure (or flow): a value typed ten times too large or small lies 90 % or more off, the knee of
# a real line's choke end (pyCycle's, GasTurb's sample maps) within 25 %
OFF_SHARE = 0.5
OFF_TIMES = 20.0  # times the median misfit of the rest: real lines sit that close to their own quadratic


def _off_by(x: np.ndarray, y: np.ndarray, j: int) -> tuple[float, float, float]:
    """Point j's distance in y from the quadratic y(x) through the other points, that curve's value at it and its
    median misfit on them, the distances as fractions of the line's median |y|."""
    rest = np.arange(len(x)) != j
    centre, span = x[rest].mean(), np.ptp(x[rest])  # conditioned for flows in m3/h and in kg/s alike
    if not span > 0:
        return 0.0, float(y[j]), np.inf
    coef = np.polyfit((x[rest] - centre) / span, y[rest], 2)
    scale = float(np.median(np.abs(y)))
    expected = float(np.polyval(coef, (x[j] - centre) / span))
    misfit = float(np.median(np.abs(np.polyval(coef, (x[rest] - centre) / span) - y[rest]))) / scale
    return abs(float(y[j]) - expected) / scale, expected, misfit


def _how_far(x: np.ndarray, y: np.ndarray, j: int) -> tuple[float, float, float, float]:
    """How many times its threshold point j lies off its line, the lesser of pressure against flow and flow against
    pressure (a choke end falls steeply, a surge end is flat: one of the two follows each), with the pressure's
    distance, expected value and the rest's misfit."""
    off, expected, misfit = _off_by(x, y, j)
    off_flow, _, misfit_flow = _off_by(y, x, j)
    times = min(off / max(OFF_SHARE, OFF_TIMES * misfit), off_flow / max(OFF_SHARE, OFF_TIMES * misfit_flow))
    return times, off, expected, misfit


def _submitted(internal: PerfmapRequest, s: Setting, x: float, y: float) -> int | None:
    """The index of the point in its position's submitted lists (the setting's points are sorted by flow)."""
    pos = internal.positions[s.source_index]
    same = [k for k, (f, p) in enumerate(zip(pos.flow, pos.pressure)) if f == x and p == y]
    return same[0] if same else None


def points_off_their_lines(settings: list[Setting], request: PerfmapRequest, internal: PerfmapRequest,
                           rows_of: list[list[int]] | None = None, row_label: str = "line",
                           heads: list[int] | None = None) -> list[Diagnostic]:
    """One ``point_off_its_line`` warning per point far off its line by the measure of the module docstring, naming
    its setting, its flow and pressure as submitted (``request``; the settings are in ``internal``'s units) and, for an
    upload, its file row (``rows_of[i][k]``: the row of point k of position i) or the line heading its speed line
    (``heads[i]``, a map file's)."""
    out: list[Diagnostic] = []
    for s in settings:
        if len(s.x) < MIN_POINTS:
            continue
        # one typo per line, its worst point (the curves through the rest and the typo bend to pass near it, so their
        # misfit is large and the others do not look off)
        j, (times, off, expected, misfit) = max(((j, _how_far(s.x, s.y, j)) for j in range(len(s.x))),
                                                key=lambda f: f[1][0])
        if times <= 1:
            continue
        k = _submitted(internal, s, float(s.x[j]), float(s.y[j]))
        if k is None:  # an average of repeated readings: repeated_points_disagree names those
            continue
        given = request.positions[s.source_index]
        flow, pressure = float(given.flow[k]), float(given.pressure[k])
        rows = rows_of[s.source_index] if rows_of and s.source_index < len(rows_of) else None
        row = rows[k] if rows and k < len(rows) else None
        where = (f"{row_label} {row}" if row is not None else
                 f"point {k + 1} of the speed line at line {heads[s.source_index]}"
                 if heads and s.source_index < len(heads) else f"positions[{s.source_index}] point {k}")
        out.append(Diagnostic(
            code="point_off_its_line",
            message=f"Setting {s.label}: the point at flow {flow:g}, pressure {pressure:g} ({where}) lies "
            f"{off:.0%} of the line's pressure off the curve through its other {len(s.x) - 1} points, which lie "
            f"{misfit:.2%} from it: a pressure or a flow mistyped (a digit dropped or added)? It is fitted as given.",
            details={"setting": list(s.values), "position": s.source_index, "point": k, "row": row,
                     "field": f"file.row.{row}" if row is not None else f"positions.{s.source_index}",
                     "flow": flow, "pressure": pressure, "expected_pressure": expected * pressure / float(s.y[j]),
                     "off": off,
                     "line_misfit": misfit}))
    return out
