"""How far two fits of the same speed lines lie apart: the measure of a map's round trip through an export."""

from __future__ import annotations

import numpy as np
import pytest

from plantsolve.solvers.perfmap.families import curveset_from_fits


def fits_agree(original, again, **span_approx) -> tuple[float, float, float]:
    """Max differences of two fits of the same lines at the same curve parameter: pressure relative (all, first
    90 % of the flow range) and efficiency absolute. The read-back line spans the fitted one's flows (its surge and
    choke nodes are the ends): ``span_approx`` is ``pytest.approx``'s tolerance for that, ``abs`` as a fraction of
    the line's flow span."""
    c1, c2 = curveset_from_fits(original.settings), curveset_from_fits(again.settings)
    by = {tuple(s.setting): k for k, s in enumerate(original.settings)}
    assert sorted(by) == sorted(tuple(s.setting) for s in again.settings)
    t = np.linspace(0, 1, 401)
    p_all = p_body = e_all = 0.0
    for k2, s in enumerate(again.settings):
        k = by[tuple(s.setting)]
        o = original.settings[k]
        tolerance = dict(span_approx)
        if "abs" in tolerance:
            tolerance["abs"] *= o.x_max - o.x_min
        assert (s.x_min, s.x_max) == pytest.approx((o.x_min, o.x_max), **tolerance)
        _, y1, e1 = c1.evaluate(np.full(t.size, k), t)
        _, y2, e2 = c2.evaluate(np.full(t.size, k2), t)
        rel = np.abs(y2 - y1) / y1
        p_all, p_body = max(p_all, rel.max()), max(p_body, rel[t <= 0.9].max())
        e_all = max(e_all, np.abs(e2 - e1).max())
    return p_all, p_body, e_all


def pressure_differences(original, again) -> dict[tuple[float, ...], float]:
    """Per setting: the max relative pressure difference of the two fits at the same curve parameter."""
    c1, c2 = curveset_from_fits(original.settings), curveset_from_fits(again.settings)
    by = {tuple(s.setting): k for k, s in enumerate(original.settings)}
    t = np.linspace(0, 1, 401)
    out = {}
    for k2, s in enumerate(again.settings):
        _, y1, _ = c1.evaluate(np.full(t.size, by[tuple(s.setting)]), t)
        _, y2, _ = c2.evaluate(np.full(t.size, k2), t)
        out[tuple(s.setting)] = float(np.max(np.abs(y2 - y1) / y1))
    return out
