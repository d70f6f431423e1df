"""Catalogue angles of PCF fittings, restored after the rounding of printed coordinates.

A PCF prints coordinates rounded to a few decimals, which bends a fitting's exact catalogue
angles (90, 45, 22.5 ... degrees; run ports exactly opposite) by up to about quantum / arm.
Loops of such fittings could never close, so angles within that rounding of a catalogue
angle are restored exactly.
"""

from __future__ import annotations

import numpy as np

from plantsolve.solvers.geometry import angle_between

STANDARD_ANGLES = np.radians([0.0, 90.0, 135.0, 120.0, 150.0, 157.5, 168.75, 180.0, 45.0, 60.0])


def _cos_sin(angle: float) -> tuple[float, float]:
    """cos and sin, exact at multiples of 45 degrees (so snapped right angles have exact zeros)."""
    k = angle / (np.pi / 4)
    if abs(k - round(k)) < 1e-12:
        h = np.sqrt(0.5)
        return [(1.0, 0.0), (h, h), (0.0, 1.0), (-h, h), (-1.0, 0.0)][int(round(k)) % 8] if 0 <= round(k) <= 4 else (
            float(np.cos(angle)), float(np.sin(angle)))
    return float(np.cos(angle)), float(np.sin(angle))


def _straight(angle: float | None) -> bool:
    return angle is not None and abs(angle - np.pi) < 1e-9


def print_quantum(point_lines: list[str]) -> float:
    """Half the last printed digit of the coordinates: how far rounding may have moved a point."""
    decimals = 0
    for line in point_lines:
        for tok in line.split()[1:4]:
            mant = tok.lower().split("e")[0]
            decimals = max(decimals, len(mant.split(".")[1]) if "." in mant else 0)
    return 0.5 * 10.0 ** -decimals


def snap_catalogue(ports, c: np.ndarray, quantum: float):
    """Catalogue fittings have exact angles (90, 45, 22.5 ... degrees; run ports exactly opposite), but a PCF
    prints coordinates rounded, which bends them by up to ~quantum / arm. Angles within that rounding of a
    multiple of 0.25 degree are restored exactly; otherwise loops of such fittings could never close."""
    P = [p for p, _ in ports]
    D = [d for _, d in ports]
    arm = [float(np.linalg.norm(p - c)) for p in P]
    if min(arm) <= 0:
        return ports
    slack = 3.0 * 2.0 * np.sqrt(3.0) * quantum / min(arm) + 1e-12  # radians
    # already exact up to the float spacing of the coordinates (e.g. a file this solver wrote): leave the bits
    exact = 64 * np.finfo(float).eps * max(1.0, float(np.max(np.abs(np.concatenate([c, *P]))))) / min(arm)

    def nice(angle: float) -> float | None:
        std = STANDARD_ANGLES[np.argmin(np.abs(STANDARD_ANGLES - angle))]
        if abs(std - angle) <= slack:
            return float(std)
        if slack < np.radians(0.05):  # fine print: any quarter degree (bends) is as good a catalogue angle
            target = np.radians(0.25) * round(np.degrees(angle) / 0.25)
            return float(target) if abs(target - angle) <= slack else None
        return None

    def towards(axis: np.ndarray, d: np.ndarray) -> np.ndarray:
        """d with its angle to the axis snapped (in the plane of axis and d)."""
        ang = angle_between(axis, d)
        tgt = nice(ang)
        e = d - (axis @ d) * axis
        n = np.linalg.norm(e)
        if tgt is None or n == 0 or abs(tgt - ang) <= exact:
            return d
        e /= n
        c_, s_ = _cos_sin(tgt)
        return c_ * axis + s_ * e

    if len(D) == 2:  # elbow / bend: symmetric about the bisector
        beta = angle_between(D[0], D[1])
        tgt = nice(beta)
        b, e = D[0] + D[1], D[1] - D[0]
        if tgt is not None and abs(tgt - beta) > exact and np.linalg.norm(b) > 0 and np.linalg.norm(e) > 0:
            b, e = b / np.linalg.norm(b), e / np.linalg.norm(e)
            c_, s_ = _cos_sin(tgt / 2)
            D = [c_ * b - s_ * e, c_ * b + s_ * e]
    else:  # tee / cross: run END-POINTs opposite, branches at exact angles to the run
        run = angle_between(D[0], D[1])
        straight = _straight(nice(run))
        a = (D[1] - D[0]) / np.linalg.norm(D[1] - D[0]) if straight else D[1]
        D[2] = towards(a, D[2])
        if len(D) > 3:
            opp = angle_between(D[2], D[3])
            if not (np.pi - opp <= exact and D[2] is ports[2][1]):
                D[3] = -D[2] if _straight(nice(opp)) else towards(a, D[3])
        if straight and (np.pi - run > exact or any(d is not d_in for d, (_, d_in) in zip(D[2:], ports[2:]))):
            D[0], D[1] = -a, a
    # the ports of a restored fitting move onto their exact catalogue axes through the centre (rounding also
    # put them a little off those axes, which would leave loops of such fittings out of plane)
    if all(d is d_in for d, (_, d_in) in zip(D, ports)):
        return ports
    return [(c + r * d, d) for r, d in zip(arm, D)]

