"""The setting lines of a request, read and checked across fields (types, finiteness and lengths are in the
schema): each sorted by flow, repeats merged or averaged, its vertical choke segment found (:func:`prepare`)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from plantsolve.schemas.perfmap import PerfmapRequest
from plantsolve.solvers.base import FieldError, InputRejected

CHOKE_FLOW_TOLERANCE = 1e-4  # flows this close to the largest (fraction of the line's flow range) are the same


@dataclass(frozen=True)
class Repeat:
    """Readings at one flow of one setting, averaged into one point."""

    flow: float
    points: tuple[int, ...]  # indices in the position's submitted lists
    pressures: tuple[float, ...]
    efficiencies: tuple[float, ...]

    @property
    def pressure_spread(self) -> float:
        """(max - min) / mean of the pressures: how far the readings disagree."""
        return (max(self.pressures) - min(self.pressures)) / float(np.mean(self.pressures))

    @property
    def efficiency_spread(self) -> float:
        return (max(self.efficiencies) - min(self.efficiencies)) / float(np.mean(self.efficiencies))


@dataclass
class Setting:
    """One setting (its values in the order of the request's setting names), points sorted by flow,
    exact duplicates merged."""

    values: tuple[float, ...]
    x: np.ndarray
    y: np.ndarray
    eta: np.ndarray
    source_index: int  # index in request.positions
    merged_duplicates: int = 0
    repeated_flows: int = 0  # readings at an already measured flow, averaged
    # each averaged group: flow, the points' indices in the submitted lists, their pressures and efficiencies
    repeats: list[Repeat] = field(default_factory=list)
    choke_pressures: list[float] = field(default_factory=list)  # a vertical choke segment at x[-1], low to high

    names: tuple[str, ...] = ("theta", "phi")

    @property
    def theta(self) -> float | None:
        return self.values[0] if len(self.values) == 2 else None

    @property
    def phi(self) -> float | None:
        return self.values[1] if len(self.values) == 2 else None

    @property
    def label(self) -> str:
        return ", ".join(f"{n}={v:g}" for n, v in zip(self.names, self.values))

    @property
    def t(self) -> np.ndarray:
        return (self.x - self.x[0]) / (self.x[-1] - self.x[0])


def _not_positive(values: np.ndarray, i: int, name: str, plural: str, errors: list[FieldError]) -> bool:
    """Whether some of a position's ``values`` are not positive, with an error naming the first (the fits'
    errors are relative, so a value at or below zero has none)."""
    if not np.any(values <= 0):
        return False
    k = int(np.argmax(values <= 0))
    errors.append(FieldError(("positions", i, name, k),
                             f"{plural} must be positive (errors are relative); got {values[k]:g}"))
    return True


def _zero_flow(x: np.ndarray, eta: np.ndarray, i: int, errors: list[FieldError]) -> bool:
    """Whether a position has a point at zero flow, with an error naming the first: no flow does no useful work, so
    an efficiency beside it (0.66 where the flow reads 0) is a flow left empty or mistyped, and a shut-off point
    (efficiency 0) lies outside what the efficiency curves fit. Fitted, it passed as a poor fit only."""
    if not np.any(x == 0):
        return False
    k = int(np.argmax(x == 0))
    errors.append(FieldError(("positions", i, "flow", k), (
        f"flow 0 beside efficiency {eta[k]:g}: at zero flow a compressor does no useful work (its efficiency is 0), "
        "so this is no point of the characteristic: a flow left empty or mistyped? (a shut-off point cannot be "
        "fitted: leave it out)" if eta[k] != 0 else
        "flow 0 and efficiency 0: a shut-off point, which the efficiency curves cannot be fitted through: leave it "
        "out")))
    return True


def _prepare_position(i: int, pos, errors: list[FieldError], values: tuple[float, ...] = (),
                      names: tuple[str, ...] = ("theta", "phi"),
                      choke_tolerance: float = CHOKE_FLOW_TOLERANCE) -> Setting | None:
    n = len(pos.flow)
    bad = False
    for name in ("pressure", "efficiency"):
        if len(getattr(pos, name)) != n:
            errors.append(FieldError(("positions", i, name),
                                     f"has {len(getattr(pos, name))} values but flow has {n}"))
            bad = True
    if bad:
        return None
    x, y, eta = (np.asarray(v, dtype=float) for v in (pos.flow, pos.pressure, pos.efficiency))
    # Point-specific errors name the point (loc ..., field, k; k = index in the submitted
    # list) so that a CSV upload can point at the file row.
    bad = _not_positive(y, i, "pressure", "pressures", errors)
    if _zero_flow(x, eta, i, errors) or _not_positive(eta, i, "efficiency", "efficiencies", errors):
        bad = True
    elif np.any(eta > 1):  # fitted curves are held to 0 <= eta <= 1
        k = int(np.argmax(eta > 1))  # the first offending point
        hint = ("percent? divide by 100, or in a CSV label the column 'efficiency [%]'"
                if eta.max() <= 100 else "efficiency must be a fraction")
        errors.append(FieldError(("positions", i, "efficiency", k),
                                 f"efficiency is a fraction, 0 < eta <= 1; got {eta[k]:g} "
                                 f"({hint})"))
        bad = True
    if bad:
        return None
    order = np.lexsort((eta, y, x))
    x, y, eta = x[order], y[order], eta[order]
    same = (np.diff(x) == 0) & (np.diff(y) == 0) & (np.diff(eta) == 0)
    keep = np.concatenate([[True], ~same])
    x, y, eta, order = x[keep], y[keep], eta[keep], order[keep]
    repeated = 0
    choke_pressures: list[float] = []
    # At the largest flow, within table rounding, a vertical choke segment: the characteristic ends at
    # its top, the rest is the choke line. Cycle-code tables print choke flows rounded, so the R-line
    # before the segment may read a hair (1e-6 relative) above it; taken literally, that order puts the
    # segment's low pressures before a higher one, a rise of tens of per cent that no curve could follow.
    choke = np.flatnonzero(x >= x[-1] - choke_tolerance * (x[-1] - x[0]))
    if len(choke) > 1:
        top = choke[int(np.argmax(y[choke]))]
        choke_pressures = sorted(float(v) for v in y[choke])
        keep = np.ones(len(x), dtype=bool)
        keep[choke] = False
        keep[top] = True
        x, y, eta, order = x[keep], y[keep], eta[keep], order[keep]
    repeats: list[Repeat] = []
    if np.any(np.diff(x) <= 0):
        # The same flow with other values elsewhere: repeated readings, averaged.
        xs, ys, es = [], [], []
        for members in np.split(np.arange(len(x)), np.flatnonzero(np.diff(x) > 0) + 1):
            xs.append(x[members[0]]); ys.append(float(np.mean(y[members]))); es.append(float(np.mean(eta[members])))
            repeated += len(members) - 1
            if len(members) > 1:
                repeats.append(Repeat(float(x[members[0]]), tuple(int(k) for k in order[members]),
                                      tuple(map(float, y[members])), tuple(map(float, eta[members]))))
        x, y, eta = np.array(xs), np.array(ys), np.array(es)
    if len(x) < 3:
        errors.append(FieldError(("positions", i, "flow"),
                                 f"needs at least 3 distinct points, got {len(x)}"))
        return None
    span = x[-1] - x[0]
    if not span > 1e-9 * max(abs(x[0]), abs(x[-1])):
        errors.append(FieldError(("positions", i, "flow"),
                                 f"the flow range {x[0]:g}..{x[-1]:g} is too narrow to fit a "
                                 "curve (relative span below 1e-9)"))
        return None
    return Setting(values, x, y, eta, i, int(np.sum(same)), repeated, repeats, choke_pressures, names)


def normalised_settings(*columns: np.ndarray) -> np.ndarray:
    """Setting values (one array per parameter, or one (n, d) matrix) scaled to [0, 1] each, so that
    geometry does not depend on units."""
    pts = (np.asarray(columns[0], dtype=float) if len(columns) == 1 and np.ndim(columns[0]) == 2
           else np.column_stack(columns).astype(float))
    lo, span = pts.min(axis=0), np.ptp(pts, axis=0)
    return (pts - lo) / np.where(span > 0, span, 1.0)


def collinear(*columns: np.ndarray) -> bool:
    pts = normalised_settings(*columns)
    if pts.shape[1] == 1:
        return True
    if len(pts) < 3:
        return True
    centred = pts - pts.mean(axis=0)
    s = np.linalg.svd(centred, compute_uv=False)
    return bool(s[1] <= 1e-9 * max(s[0], 1e-300))


def settings_rank(values: np.ndarray) -> int:
    """Dimension of the affine hull of the (range-normalised) settings: 0..3."""
    pts = normalised_settings(values)
    if len(pts) < 2:
        return 0
    s = np.linalg.svd(pts - pts.mean(axis=0), compute_uv=False)
    return int(np.sum(s > 1e-9 * max(s[0], 1e-300)))


def map_impossible(settings: list[Setting]) -> str | None:
    """Why no performance map can be built over these settings (None when it can). Settings on one
    line (a single setting parameter, e.g. speed lines) give the one-parameter map."""
    if len(settings) < 2:
        return f"a performance map needs at least 2 settings, got {len(settings)}"
    return None


def prepare(request: PerfmapRequest, choke_tolerance: float = CHOKE_FLOW_TOLERANCE) -> list[Setting]:
    """Validate and return the settings sorted by their values; raises InputRejected. ``choke_tolerance``:
    flows within this fraction of a line's flow range of its largest are its vertical choke segment."""
    errors: list[FieldError] = []
    settings: list[Setting] = []
    seen: dict[tuple[float, ...], int] = {}
    names = tuple(request.setting_names)
    for i, pos in enumerate(request.positions):
        key = tuple(float(v) for v in request.setting_values(i))
        if key in seen:
            label = ", ".join(f"{n}={v:g}" for n, v in zip(names, key))
            errors.append(FieldError(("positions", i),
                                     f"setting ({label}) repeats "
                                     f"positions[{seen[key]}]; merge their points"))
            continue
        seen[key] = i
        s = _prepare_position(i, pos, errors, key, names, choke_tolerance)
        if s is not None:
            settings.append(s)
    if not errors and request.options.map:  # an explicitly requested map must be possible
        reason = map_impossible(settings)
        if reason:
            errors.append(FieldError(("positions",), reason + " (set options.map=false, or "
                                     "leave it unset, for characteristics and envelopes only)"))
    if errors:
        raise InputRejected(errors)
    settings.sort(key=lambda s: s.values)
    return settings
