"""Scan-like test networks: a grid of fittings joined by pipes (every cell is a loop).

Used by the tests, the benchmark and the examples; :func:`conflicting_tie_ins` moves one of two
tie-ins so that the network has to be cut. Nodes of degree 2/3/4 get an elbow, a
tee or a cross; every ``valve_every``-th edge gets an inline valve (pipe-valve-pipe); the
listed corners are tie-ins placed exactly; everything else is perturbed like a scan fit
(pipes ~2 mm / 0.3 deg, fittings ~6 mm / 1.5 deg by default). Seeded, so deterministic.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from plantsolve.schemas.alignment import AlignmentRequest


def grid_network(
    nx: int, ny: int, *, spacing: float = 3000.0, arm: float = 150.0, radius: float = 50.0,
    origin: tuple[float, float, float] = (0.0, 0.0, 0.0), valve_every: int = 0,
    tie_ins: tuple[tuple[int, int], ...] = (), pipe_noise: tuple[float, float] = (2.0, 0.3),
    fitting_noise: tuple[float, float] = (6.0, 1.5), seed: int = 0, options: dict | None = None,
) -> AlignmentRequest:
    rng = np.random.default_rng(seed)
    org = np.array(origin, dtype=float)
    comps: list[dict] = []
    conns: list[dict] = []
    node_port: dict[tuple[int, int, int, int], tuple[str, int]] = {}

    def perturb(ports, centre, noise, fixed, up=None):
        if fixed or noise == (0.0, 0.0):
            return ports, up
        rot = Rotation.from_rotvec(rng.normal(size=3) * np.radians(noise[1]) / np.sqrt(3))
        shift = rng.normal(size=3) * noise[0] / np.sqrt(3)
        out = []
        for p, d in ports:
            out.append((rot.apply(np.asarray(p) - centre) + centre + shift, rot.apply(d)))
        return out, (None if up is None else rot.apply(up).tolist())

    def add(cid, kind, ftype, ports, centre, noise, fixed=False, up=None):
        ports, up = perturb(ports, centre, noise, fixed, up)
        comp = {"id": cid, "kind": kind, "radius": radius, "fixed": fixed,
                "ports": [{"position": (np.asarray(p) + org).tolist(), "direction": np.asarray(d).tolist()} for p, d in ports]}
        if kind == "fitting":
            comp["type"] = ftype
        if up is not None:
            comp["up"] = up
        comps.append(comp)

    dirs = {(1, 0): 0, (-1, 0): 1, (0, 1): 2, (0, -1): 3}
    for i in range(nx):
        for j in range(ny):
            c = np.array([i * spacing, j * spacing, 0.0])
            nbrs = [(di, dj) for (di, dj) in dirs if 0 <= i + di < nx and 0 <= j + dj < ny]
            ftype = {1: "cap", 2: "elbow", 3: "tee", 4: "cross"}[len(nbrs)]
            if len(nbrs) == 2 and nbrs[0][0] == -nbrs[1][0] and nbrs[0][1] == -nbrs[1][1]:
                ftype = "other"
            ports = [(c + arm * np.array([di, dj, 0.0]), np.array([di, dj, 0.0])) for di, dj in nbrs]
            cid = f"N{i}-{j}"
            add(cid, "fitting", ftype, ports, c, fitting_noise, fixed=(i, j) in tie_ins)
            for k, (di, dj) in enumerate(nbrs):
                node_port[(i, j, di, dj)] = (cid, k)
    edge = 0
    for i in range(nx):
        for j in range(ny):
            for di, dj in ((1, 0), (0, 1)):
                if not (i + di < nx and j + dj < ny):
                    continue
                a = np.array([i * spacing, j * spacing, 0.0])
                e = np.array([di, dj, 0.0])
                start, end = a + arm * e, a + (spacing - arm) * e
                edge += 1
                if valve_every and edge % valve_every == 0:
                    mid = 0.5 * (start + end)
                    v0, v1 = mid - 150 * e, mid + 150 * e
                    add(f"P{edge}a", "pipe", None, [(start, -e), (v0, e)], 0.5 * (start + v0), pipe_noise)
                    add(f"V{edge}", "fitting", "valve", [(v0, -e), (v1, e)], mid, fitting_noise, up=[0.0, 0.0, 1.0])
                    add(f"P{edge}b", "pipe", None, [(v1, -e), (end, e)], 0.5 * (v1 + end), pipe_noise)
                    chain = [(f"P{edge}a", 0), (f"P{edge}a", 1), (f"V{edge}", 0), (f"V{edge}", 1), (f"P{edge}b", 0), (f"P{edge}b", 1)]
                else:
                    add(f"P{edge}", "pipe", None, [(start, -e), (end, e)], 0.5 * (start + end), pipe_noise)
                    chain = [(f"P{edge}", 0), (f"P{edge}", 1)]
                ends = [node_port[(i, j, di, dj)]] + chain + [node_port[(i + di, j + dj, -di, -dj)]]
                for k in range(0, len(ends), 2):
                    conns.append({"from": list(ends[k]), "to": list(ends[k + 1])})
    return AlignmentRequest.model_validate(
        {"units": "mm", "components": comps, "connections": conns, "options": options or {}}
    )


def example() -> dict:
    """A small request for the API docs and the contract test: a 2 × 2 loop with an inline
    valve and one tie-in, scan-like gaps, solved in well under a second."""
    request = grid_network(2, 2, valve_every=3, tie_ins=((0, 0),), seed=1)
    return request.model_dump(mode="json", exclude_none=True)


def conflicting_tie_ins(nx: int, ny: int, *, seed: int = 0, shift: tuple[float, float, float] = (0.0, 0.0, 0.0),
                        turn: float = 0.0, valve_every: int = 0, options: dict | None = None) -> AlignmentRequest:
    """A scan-like grid (:func:`grid_network`, plant coordinates around 1e6 mm) with tie-ins at two opposite
    corners, the second placed ``shift`` (mm) and ``turn`` (degrees about z) away from where the grid has it:
    the network cannot close as measured, so connections have to be cut (or pipes stretched)."""
    req = grid_network(nx, ny, seed=seed, valve_every=valve_every, tie_ins=((0, 0), (nx - 1, ny - 1)),
                       origin=(1.0e6, 2.0e5, 1.0e4), options={"method": "direct", **(options or {})})
    comps = [c.model_copy(deep=True) for c in req.components]
    moved = next(c for c in comps if c.id == f"N{nx - 1}-{ny - 1}")
    R = Rotation.from_rotvec([0.0, 0.0, np.radians(turn)])
    centre = np.mean([p.position for p in moved.ports], axis=0)
    for p in moved.ports:
        p.position = (R.apply(np.array(p.position) - centre) + centre + np.asarray(shift, dtype=float)).tolist()
        p.direction = R.apply(p.direction).tolist()
    return req.model_copy(update={"components": comps})


def reordered(req: AlignmentRequest, seed: int = 1) -> AlignmentRequest:
    """The same network written in another order: components and connections shuffled and about half the
    connections named from their other end (seeded). A solve must not tell the two apart."""
    body = req.model_dump(mode="json", by_alias=True)
    rng = np.random.default_rng(seed)
    body["components"] = [body["components"][i] for i in rng.permutation(len(body["components"]))]
    conns = [body["connections"][i] for i in rng.permutation(len(body["connections"]))]
    body["connections"] = [{"from": c["to"], "to": c["from"]} if rng.random() < 0.5 else c for c in conns]
    return AlignmentRequest.model_validate(body)
