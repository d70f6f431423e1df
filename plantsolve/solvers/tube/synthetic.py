"""Synthetic tubes and a laser-scan simulator (tests and ``bench/tube.py``).

Area-correct sampling of the pipe surface (a torus patch has area element
r·(1 − κ r cos v) du dv, sampled by rejection), an optional single viewpoint (only
samples whose normal faces the scanner are kept), Gaussian noise along the normal and
uniform outliers in the bounding box. Deterministic for a given ``numpy`` Generator.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from plantsolve.solvers.tube.model import TubeModel, build_spine, sample_centreline


def make_model(rows, pipe_radius: float, start=(0.0, 0.0, 0.0), frame=None) -> TubeModel:
    """Model from LRA rows ``(length, rotation_deg, angle_deg, bend_radius)``."""
    rows = np.asarray(rows, float).reshape(-1, 4)
    n = len(rows) - 1
    f = np.eye(3) if frame is None else np.asarray(frame, float)
    return TubeModel(np.asarray(start, float), f, rows[:, 0].copy(), np.radians(rows[:, 1]),
                     np.radians(rows[:n, 2]), rows[:n, 3].copy(), float(pipe_radius))


def random_rotation(rng: np.random.Generator) -> np.ndarray:
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    w, x, y, z = q
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


def random_tube(rng: np.random.Generator, pipe_radius: float | None = None, n_bends: int | None = None) -> TubeModel:
    """A random bendable tube: bend radius 2–4 r, back-to-back bends, tiny and >180° bends."""
    r = float(pipe_radius if pipe_radius is not None else np.exp(rng.uniform(np.log(1.0), np.log(50.0))))
    n = int(n_bends if n_bends is not None else rng.integers(1, 9))
    rb = rng.uniform(2.0, 4.0, size=n) * r
    ang = np.radians(rng.uniform(15.0, 120.0, size=n))
    kind = rng.random(n)
    ang[kind < 0.12] = np.radians(rng.uniform(3.0, 8.0, size=int((kind < 0.12).sum())))
    big = (kind > 0.92)
    ang[big] = np.radians(rng.uniform(181.0, 215.0, size=int(big.sum())))
    lengths = rng.uniform(2.0, 8.0, size=n + 1) * r
    lengths[0] = rng.uniform(6.0, 12.0) * r
    lengths[-1] = rng.uniform(6.0, 12.0) * r
    b2b = rng.random(n + 1) < 0.15
    b2b[0] = b2b[-1] = False
    lengths[b2b] = 0.0
    # a small bend needs long legs to be visible at all: ≥ 8 r on both sides
    for i in np.flatnonzero(ang < np.radians(10)):
        lengths[i] = max(lengths[i], 8 * r)
        lengths[i + 1] = max(lengths[i + 1], 8 * r)
    # bends of 180° or more would collide with their own legs unless the next plane turns away
    rot = rng.uniform(-180, 180, size=n + 1)
    rot[0] = 0.0
    rot[-1] = 0.0
    for i in np.flatnonzero(ang > np.pi):
        lengths[i + 1] = max(lengths[i + 1], 3 * r)
        if i + 1 < n:
            rot[i + 1] = rng.choice([-1, 1]) * rng.uniform(70, 110)
    m = TubeModel(rng.normal(size=3) * 10 * r, random_rotation(rng), lengths, np.radians(rot), ang, rb, r)
    return m


def clear_tube(rng: np.random.Generator, *, pipe_radius: float | None = None, n_bends: int | None = None,
               min_bends: int = 0) -> TubeModel:
    """:func:`random_tube` drawn again until it bends at least ``min_bends`` times and keeps 2.5 pipe radii clear
    of itself (:func:`clearance`), so that a scan of it has one reading."""
    while True:
        model = random_tube(rng, pipe_radius=pipe_radius, n_bends=n_bends)
        if model.n_bends >= min_bends and clearance(model) > 2.5:
            return model


def clearance(model: TubeModel) -> float:
    """Smallest distance between centreline points more than π·r_B + 4 r apart along the
    tube, in pipe radii (< 2 means the tube runs through itself)."""
    r = model.pipe_radius
    c, _ = sample_centreline(model, r / 2)
    s = np.concatenate([[0], np.cumsum(np.linalg.norm(np.diff(c, axis=0), axis=1))])
    gap = np.pi * (model.radii.max() if model.n_bends else 0) + 4 * r
    pairs = cKDTree(c).query_pairs(4 * r, output_type="ndarray")
    if len(pairs) == 0:
        return np.inf
    far = np.abs(s[pairs[:, 0]] - s[pairs[:, 1]]) > gap
    if not far.any():
        return np.inf
    return float(np.linalg.norm(c[pairs[far, 0]] - c[pairs[far, 1]], axis=1).min() / r)


def surface_samples(model: TubeModel, n: int, rng: np.random.Generator, view: np.ndarray | None = None,
                    noise: float = 0.0, outlier_fraction: float = 0.0) -> np.ndarray:
    """Scan-like samples of the tube surface (see module doc)."""
    sp = build_spine(model)
    r = model.pipe_radius
    seg_len = np.maximum(sp.length, 0.0)
    total = seg_len.sum()
    out = []
    n_out = int(round(outlier_fraction * n))
    need_surface = n - n_out
    got = 0
    view = None if view is None else np.asarray(view, float) / np.linalg.norm(view)
    while got < need_surface:
        m = max(2 * (need_surface - got), 1000) * (3 if view is not None else 1)
        s = rng.uniform(0, total, m)
        v = rng.uniform(0, 2 * np.pi, m)
        k = np.clip(np.searchsorted(np.cumsum(seg_len), s, side="right"), 0, len(seg_len) - 1)
        loc = s - (np.cumsum(seg_len) - seg_len)[k]
        is_arc = sp.kind[k] == 1
        kap = np.where(is_arc, 1.0 / np.where(sp.radius[k] > 0, sp.radius[k], 1.0), 0.0)
        keep = rng.uniform(0, 1 + kap * r) <= 1 - kap * r * np.cos(v)
        t0, n0 = sp.tangent[k], sp.normal[k]
        phi = np.where(is_arc, loc * kap, 0.0)
        c_line = sp.start[k] + loc[:, None] * t0
        R = sp.radius[k][:, None]
        c_arc = sp.centre[k] - R * np.cos(phi)[:, None] * n0 + R * np.sin(phi)[:, None] * t0
        c = np.where(is_arc[:, None], c_arc, c_line)
        t = np.where(is_arc[:, None], np.cos(phi)[:, None] * t0 + np.sin(phi)[:, None] * n0, t0)
        nn = np.where(is_arc[:, None], np.cos(phi)[:, None] * n0 - np.sin(phi)[:, None] * t0, n0)
        b = np.cross(t, nn)
        normal = np.cos(v)[:, None] * nn + np.sin(v)[:, None] * b
        # cos v = +1 points toward the bend centre: that is the inside, with less area
        p = c + r * normal
        if view is not None:
            keep &= (normal @ -view) > 0.05
        p, normal = p[keep], normal[keep]
        if noise:
            p = p + rng.normal(0, noise, len(p))[:, None] * normal
        out.append(p)
        got += len(p)
    pts = np.vstack(out)[:need_surface]
    if n_out:
        lo, hi = pts.min(0), pts.max(0)
        pad = 0.2 * (hi - lo) + r
        pts = np.vstack([pts, rng.uniform(lo - pad, hi + pad, size=(n_out, 3))])
    return pts[rng.permutation(len(pts))]


def small_bends_tube(rng: np.random.Generator, pipe_radius: float = 20.0, n_bends: int = 7, n_small: int = 3) -> TubeModel:
    """Many bends on one die of 3 r, ``n_small`` of them only 3.6–5° (the others 15–90°), straights of
    3–9 r between them and 6–9 r at the ends, bend planes turned at random; redrawn until the tube
    clears itself by 2.5 r."""
    r = float(pipe_radius)
    while True:
        ang = rng.uniform(15.0, 90.0, size=n_bends)
        ang[rng.choice(n_bends, n_small, replace=False)] = rng.uniform(3.6, 5.0, size=n_small)
        lengths = rng.uniform(3.0, 9.0, size=n_bends + 1) * r
        lengths[[0, -1]] = rng.uniform(6.0, 9.0, size=2) * r
        rot = rng.uniform(-180.0, 180.0, size=n_bends + 1)
        rot[[0, -1]] = 0.0
        rows = np.column_stack([lengths, rot, np.append(ang, 0.0), np.append(np.full(n_bends, 3.0 * r), 0.0)])
        m = make_model(rows, r, start=rng.normal(size=3) * 10 * r, frame=random_rotation(rng))
        if clearance(m) > 2.5:
            return m


__all__ = ["make_model", "random_tube", "clear_tube", "surface_samples", "random_rotation", "clearance", "small_bends_tube"]


def example() -> dict:
    """A small request for the API docs and the contract test: a single-view scan of a 4 mm
    tube with one 90° bend on a 12 mm radius, 1,500 samples printed to 0.001 mm (a second)."""
    rng = np.random.default_rng(11)
    model = make_model([[30.0, 0.0, 90.0, 12.0], [30.0, 0.0, 0.0, 0.0]], 4.0)
    pts = surface_samples(model, 1500, rng, view=np.array([0.2, 0.3, -1.0]), noise=0.02)
    return {"points": np.round(pts, 3).tolist(), "units": "mm"}
