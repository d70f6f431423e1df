"""Semantic input checks (cross-field; types, finiteness and lengths are in the schema)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from schemas.perfmap import PerfmapRequest
from solvers.base import FieldError, InputRejected


@dataclass
class Setting:
    """One (theta, phi) setting, points sorted by flow, exact duplicates merged."""

    theta: float
    phi: float
    x: np.ndarray
    y: np.ndarray
    eta: np.ndarray
    source_index: int  # index in request.positions
    merged_duplicates: int = 0

    @property
    def t(self) -> np.ndarray:
        return (self.x - self.x[0]) / (self.x[-1] - self.x[0])


def _prepare_position(i: int, pos, errors: list[FieldError]) -> Setting | None:
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
    if np.any(y <= 0):
        errors.append(FieldError(("positions", i, "pressure"),
                                 "pressures must be positive (errors are relative)"))
        bad = True
    if np.any(eta <= 0):
        errors.append(FieldError(("positions", i, "efficiency"),
                                 "efficiencies must be positive (errors are relative)"))
        bad = True
    elif np.any(eta > 1):  # fitted curves are held to 0 <= eta <= 1
        errors.append(FieldError(("positions", i, "efficiency"),
                                 f"efficiency is a fraction, 0 < eta <= 1; got {eta.max():g} "
                                 "(percent? divide by 100)"))
        bad = True
    if bad:
        return None
    order = np.lexsort((eta, y, x))
    x, y, eta = x[order], y[order], eta[order]
    same = (np.diff(x) == 0) & (np.diff(y) == 0) & (np.diff(eta) == 0)
    keep = np.concatenate([[True], ~same])
    x, y, eta = x[keep], y[keep], eta[keep]
    if np.any(np.diff(x) <= 0):
        k = int(np.argmax(np.diff(x) <= 0))
        errors.append(FieldError(("positions", i, "flow"),
                                 f"flow is not strictly increasing after sorting: flow {x[k]:g} "
                                 "appears twice with different pressure/efficiency"))
        return None
    if len(x) < 3:
        errors.append(FieldError(("positions", i, "flow"),
                                 f"needs at least 3 distinct points, got {len(x)}"))
        return None
    return Setting(pos.theta, pos.phi, x, y, eta, i, int(np.sum(same)))


def normalised_settings(theta: np.ndarray, phi: np.ndarray) -> np.ndarray:
    """(theta, phi) scaled to [0, 1] each, so that geometry does not depend on units."""
    pts = np.column_stack([theta, phi]).astype(float)
    lo, span = pts.min(axis=0), np.ptp(pts, axis=0)
    return (pts - lo) / np.where(span > 0, span, 1.0)


def collinear(theta: np.ndarray, phi: np.ndarray) -> bool:
    pts = normalised_settings(theta, phi)
    if len(pts) < 3:
        return True
    centred = pts - pts.mean(axis=0)
    s = np.linalg.svd(centred, compute_uv=False)
    return bool(s[1] <= 1e-9 * max(s[0], 1e-300))


def prepare(request: PerfmapRequest) -> list[Setting]:
    """Validate and return the settings sorted by (theta, phi); raises InputRejected."""
    errors: list[FieldError] = []
    settings: list[Setting] = []
    seen: dict[tuple[float, float], int] = {}
    for i, pos in enumerate(request.positions):
        key = (float(pos.theta), float(pos.phi))
        if key in seen:
            errors.append(FieldError(("positions", i),
                                     f"setting (theta={key[0]:g}, phi={key[1]:g}) repeats "
                                     f"positions[{seen[key]}]; merge their points"))
            continue
        seen[key] = i
        s = _prepare_position(i, pos, errors)
        if s is not None:
            settings.append(s)
    if not errors and request.options.map:
        th = np.array([s.theta for s in settings])
        ph = np.array([s.phi for s in settings])
        if len(settings) < 3:
            errors.append(FieldError(("positions",),
                                     f"a performance map needs at least 3 settings, got "
                                     f"{len(settings)} (set options.map=false for "
                                     "characteristics and envelopes only)"))
        elif collinear(th, ph):
            errors.append(FieldError(("positions",),
                                     "all settings lie on one line in (theta, phi): no "
                                     "triangle to interpolate over (set options.map=false "
                                     "for characteristics and envelopes only)"))
    if errors:
        raise InputRejected(errors)
    settings.sort(key=lambda s: (s.theta, s.phi))
    return settings


def check_input(request: PerfmapRequest) -> None:
    """Fast semantic validation; raises :class:`InputRejected` naming each bad field."""
    prepare(request)
