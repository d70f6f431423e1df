"""Values for the next part from one inspected part: LRA deltas that undo the measured deviations, with the
bend angle corrected for springback.

The bender was commanded the nominal angle and the part came out at the measured one: springback =
commanded − measured, and the next command is nominal + springback (``per_bend``). Bends bent on one die
spring back alike; ``linear_per_die`` fits angle_out = k · angle_cmd + b by least squares over the bends of a
die (bends sharing a nominal CLR) and commands (nominal − b) / k, which carries the springback of one bend to
the others of its die. Length and rotation have no springback: their deltas are the negated deviations. The
CLR is tooling and stays nominal.
"""

from __future__ import annotations

import numpy as np

from plantsolve.schemas.tube import Correction, LraRow, SpringbackFit
from plantsolve.solvers.geometry import wrap_angle

MAX_ANGLE = 359.999


def die_groups(nominal: list[LraRow]) -> dict[float, list[int]]:
    """0-based bend indices by nominal CLR (equal to 1e-9 relative)."""
    groups: dict[float, list[int]] = {}
    for i, r in enumerate(nominal[:-1]):
        key = next((k for k in groups if abs(k - r.bend_radius) <= 1e-9 * max(k, r.bend_radius)), r.bend_radius)
        groups.setdefault(key, []).append(i)
    return groups


def springback_fits(nominal: list[LraRow], measured: list[LraRow]) -> list[SpringbackFit]:
    """angle_out = k · angle_cmd + b per die; k = 1 (a constant springback) when the die's commanded angles do
    not spread (fewer than two distinct ones) or the fit is not increasing."""
    out = []
    for clr, idx in die_groups(nominal).items():
        cmd = np.array([nominal[i].angle for i in idx])
        got = np.array([measured[i].angle for i in idx])
        k, b = 1.0, float(np.mean(got - cmd))
        if len(idx) >= 2 and np.ptp(cmd) > 1e-6:
            k_fit, b_fit = np.polyfit(cmd, got, 1)
            if k_fit > 0.1:
                k, b = float(k_fit), float(b_fit)
        out.append(SpringbackFit(bend_radius=float(clr), bends=[i + 1 for i in idx], k=k, b=b))
    return out


def corrections(nominal: list[LraRow], measured: list[LraRow],
                model: str = "per_bend") -> tuple[list[Correction], list[SpringbackFit]]:
    """One correction per LRA row (equal bend counts, the nominal's order)."""
    n = len(nominal) - 1
    fits = springback_fits(nominal, measured) if model == "linear_per_die" and n else []
    die_of = {b - 1: f for f in fits for b in f.bends}
    out = []
    for i, (nr, mr) in enumerate(zip(nominal, measured)):
        d_len = -(mr.length - nr.length)
        d_rot = -float(wrap_angle(mr.rotation - nr.rotation, 360.0)) if 0 < i < n else 0.0
        springback, d_ang = None, 0.0
        if i < n:
            springback = nr.angle - mr.angle
            if i in die_of:
                f = die_of[i]
                d_ang = (nr.angle - f.b) / f.k - nr.angle
            else:
                d_ang = springback
        nxt = LraRow(length=max(nr.length + d_len, 0.0),
                     rotation=float(wrap_angle(nr.rotation + d_rot, 360.0)) if 0 < i < n else 0.0,
                     angle=float(np.clip(nr.angle + d_ang, 0.0, MAX_ANGLE)) if i < n else 0.0,
                     bend_radius=nr.bend_radius if i < n else 0.0)
        out.append(Correction(row=i + 1, delta_length=d_len, delta_rotation=d_rot, delta_angle=d_ang,
                              springback=springback, next=nxt))
    return out, fits
