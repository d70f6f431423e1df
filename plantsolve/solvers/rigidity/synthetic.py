"""Mechanisms with known mobility (request bodies), the small ``example()``, and random LEGO-like
models for the benchmark."""

from __future__ import annotations

import numpy as np
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation

from plantsolve.solvers.rigidity.catalogue import CATALOGUE


def hinge_joint(jid, a, b, point, axis, kind="hinge") -> dict:
    return {"id": jid, "type": kind, "bodies": [a, b], "point": list(point), "axis": list(axis)}


def _bodies(names) -> list[dict]:
    return [{"id": n} for n in names]


def four_bar() -> dict:
    """A planar four-bar: four parallel hinges (dof 1, generically rigid: generic dof 0)."""
    pts = [(0, 0, 0), (40, 0, 0), (50, 30, 0), (0, 20, 0)]
    names = ["ground", "crank", "coupler", "rocker"]
    return {"units": "mm", "bodies": _bodies(names),
            "joints": [hinge_joint(f"J{k + 1}", names[k], names[(k + 1) % 4], pts[k], (0, 0, 1)) for k in range(4)]}


def collinear_hinges() -> dict:
    """Two bodies joined by two hinges on one line (a door on two pins): dof 1."""
    return {"units": "mm", "bodies": _bodies(["frame", "door"]),
            "joints": [hinge_joint("top", "frame", "door", (0, 0, 0), (0, 0, 1)),
                       hinge_joint("bottom", "frame", "door", (0, 0, 200), (0, 0, 2))]}


def sarrus() -> dict:
    """Sarrus linkage: two legs of three parallel hinges, the legs' axes not parallel: dof 1."""
    names = ["base", "top", "l1a", "l1b", "l2a", "l2b"]
    return {"units": "mm", "bodies": _bodies(names), "joints": [
        hinge_joint("a1", "base", "l1a", (0, 0, 0), (1, 0, 0)), hinge_joint("a2", "l1a", "l1b", (0, 5, 5), (1, 0, 0)),
        hinge_joint("a3", "l1b", "top", (0, 0, 10), (1, 0, 0)),
        hinge_joint("b1", "base", "l2a", (10, 0, 0), (0, 1, 0)), hinge_joint("b2", "l2a", "l2b", (15, 0, 5), (0, 1, 0)),
        hinge_joint("b3", "l2b", "top", (10, 0, 10), (0, 1, 0))]}


def random_loop(n: int, seed: int = 0) -> dict:
    """A closed loop of n hinges on random integer lines (6R: rigid, 7R: dof 1)."""
    rng = np.random.default_rng(seed)
    names = [f"L{k}" for k in range(n)]
    joints = []
    for k in range(n):
        axis = rng.integers(-5, 6, 3)
        while not axis.any():
            axis = rng.integers(-5, 6, 3)
        joints.append(hinge_joint(f"J{k}", names[k], names[(k + 1) % n], rng.integers(-100, 101, 3).tolist(), axis.tolist()))
    return {"units": "mm", "bodies": _bodies(names), "joints": joints}


def _dh(theta, a, alpha) -> np.ndarray:
    ct, st, ca, sa = np.cos(theta), np.sin(theta), np.cos(alpha), np.sin(alpha)
    return np.array([[ct, -st * ca, st * sa, a * ct], [st, ct * ca, -ct * sa, a * st], [0, sa, ca, 0], [0, 0, 0, 1]])


def bennett(theta1: float = 0.7, a: float = 100.0, alpha_deg: float = 30.0, beta_deg: float = 60.0) -> dict:
    """The Bennett linkage: four hinges, opposite links equal (a, α) and (b, β) with a/sin α = b/sin β,
    assembled at joint angle θ1 by closing the loop numerically (residual below 1e-12): dof 1."""
    alpha, beta = np.radians(alpha_deg), np.radians(beta_deg)
    b = a * np.sin(beta) / np.sin(alpha)
    links = [(a, alpha), (b, beta), (a, alpha), (b, beta)]

    def chain(thetas):
        frames = [np.eye(4)]
        for th, (ai, al) in zip(thetas, links):
            frames.append(frames[-1] @ _dh(th, ai, al))
        return frames

    def residual(x):
        return (chain([theta1, *x])[-1] - np.eye(4))[:3].ravel()

    best = None
    for guess in ([1.0, -theta1, -1.0], [-1.0, theta1, 1.0], [2.0, 2.0 * np.pi - theta1, -2.0], [0.5, 0.5, 0.5]):
        sol = least_squares(residual, guess, xtol=1e-15, ftol=1e-15, gtol=1e-15)
        if best is None or sol.cost < best.cost:
            best = sol
    frames = chain([theta1, *best.x])
    if np.abs(residual(best.x)).max() > 1e-9:
        raise RuntimeError("Bennett loop did not close")
    names = ["L0", "L1", "L2", "L3"]
    joints = [hinge_joint(f"J{k}", names[(k - 1) % 4], names[k], frames[k][:3, 3].tolist(), frames[k][:3, 2].tolist())
              for k in range(4)]
    return {"units": "mm", "bodies": _bodies(names), "joints": joints}


def idler_chains() -> dict:
    """A–C–B with both hinges on line L, A–D–B with both on L′ ≠ L: dof 2, clusters {A, B}, {C}, {D}."""
    return {"units": "mm", "bodies": _bodies("ABCD"), "joints": [
        hinge_joint("AC", "A", "C", (0, 0, 0), (1, 0, 0)), hinge_joint("CB", "C", "B", (50, 0, 0), (1, 0, 0)),
        hinge_joint("AD", "A", "D", (0, 30, 0), (0, 1, 1)), hinge_joint("DB", "D", "B", (0, 40, 10), (0, 1, 1))]}


def open_chain(n: int = 3) -> dict:
    names = [f"B{k}" for k in range(n + 1)]
    axes = [(0, 0, 1), (1, 0, 0), (0, 1, 1), (1, 2, 3)]
    return {"units": "mm", "bodies": _bodies(names),
            "joints": [hinge_joint(f"J{k}", names[k], names[k + 1], (10 * k, 3 * k, 0), axes[k % 4]) for k in range(n)]}


def ball_joint() -> dict:
    return {"units": "mm", "bodies": _bodies(["socket", "ball"]),
            "joints": [{"id": "B", "type": "ball", "bodies": ["socket", "ball"], "point": [1, 2, 3]}]}


def moved(body: dict, rotation: Rotation, shift) -> dict:
    """The same request after a rigid motion of everything (points, axes, box shapes)."""
    out = {**body, "joints": [], "bodies": []}
    shift = np.asarray(shift, dtype=float)
    for j in body["joints"]:
        j = dict(j)
        j["point"] = (rotation.apply(np.asarray(j["point"], float)) + shift).tolist()
        if j.get("axis") is not None:
            j["axis"] = rotation.apply(np.asarray(j["axis"], float)).tolist()
        out["joints"].append(j)
    for b in body["bodies"]:
        b = dict(b)
        if b.get("shape") and b["shape"].get("box"):
            box = dict(b["shape"]["box"])
            box["center"] = (rotation.apply(np.asarray(box["center"], float)) + shift).tolist()
            q = Rotation.from_quat(np.roll(box.get("rotation", [1, 0, 0, 0]), -1))
            box["rotation"] = np.roll((rotation * q).as_quat(), 1).tolist()
            b["shape"] = {"box": box}
        out["bodies"].append(b)
    return out


def example() -> dict:
    """A four-bar with box-shaped links plus a door on two collinear hinges: solves in milliseconds."""
    body = four_bar()
    sizes = {"ground": ([20, 10, 4], [40, 4, 4]), "crank": ([45, 15, 4], [4, 30, 4]),
             "coupler": ([25, 25, 4], [50, 4, 4]), "rocker": ([0, 10, 8], [4, 20, 4])}
    for b in body["bodies"]:
        center, size = sizes[b["id"]]
        b["shape"] = {"box": {"center": center, "size": size, "rotation": [1, 0, 0, 0]}}
    body["bodies"].append({"id": "door", "shape": None})
    body["joints"].append(hinge_joint("door-top", "ground", "door", [0, 0, 0], [0, 1, 0]))
    body["joints"].append(hinge_joint("door-bottom", "ground", "door", [0, 50, 0], [0, 1, 0]))
    body["options"] = {"contact_tolerance": 0.01}
    return body


# ------------------------------------------------------------------ LEGO models

ROT_Y90 = [0, 0, 1, 0, 1, 0, -1, 0, 0]  # a quarter turn about y: x onto −z (pins and axles into z holes)
IDENTITY = [1, 0, 0, 0, 1, 0, 0, 0, 1]
HINGE_PAIR = ("3937", "3938")  # one 1 x 2 brick's cells, both parts at the same position and rotation


def stacked(studs: int = 8) -> dict:
    """Two bricks, the upper on ``studs`` studs of the lower (8: one superbrick; 1: a hinge)."""
    if studs == 8:
        return {"parts": [{"id": "low", "part": "3001", "position": [0, 0, 0]},
                          {"id": "high", "part": "3001", "position": [0, -24, 0]}]}
    return {"parts": [{"id": "low", "part": "3001", "position": [0, 0, 0]},
                      {"id": "high", "part": "3005", "position": [30, -24, 10]}]}


def _footprint(number: str, rotation: list) -> tuple[int, int, int]:
    """Cells (20 × 8 × 20 LDU) a part covers along x, y, z."""
    size = CATALOGUE["3004" if number in HINGE_PAIR else number].box_size
    nx, ny, nz = round(size[0] / 20), round(size[1] / 8), round(size[2] / 20)
    return (nz, ny, nx) if rotation == ROT_Y90 else (nx, ny, nz)


def random_lego(n_parts: int, seed: int = 0) -> list[dict]:
    """A random model of ``n_parts`` parts on the LDraw grid, built upwards: bricks and plates put on
    a random earlier part with a random overlap (several studs: rigid; one stud: a hinge), hinge
    bricks (3937 with its 3938 top at the same position: together the cells of a 1 × 2 brick), and
    pairs of technic bricks side by side joined by a pin (2780, turned so its x axis runs along the
    holes' z). Parts are placed by grid cells (20 × 8 × 20 LDU, stud centres at odd multiples of 10)
    and no two parts share a cell (the pin lies inside its bricks), so the model has no collisions."""
    rng = np.random.default_rng(seed)
    occupied: set[tuple[int, int, int]] = set()
    parts: list[dict] = []
    cells_of: list[tuple[int, int, int, int, int] | None] = []  # (cx, level, cz, nx, nz); None: nothing on top

    def place(number, cx, level, cz, rotation=IDENTITY, commit=True, cells=True) -> bool:
        nx, ny, nz = _footprint(number, rotation)
        cover = [(cx + i, level + j, cz + k) for i in range(nx) for j in range(ny) for k in range(nz)]
        if cells and any(c in occupied for c in cover):
            return False
        if commit:
            if cells:
                occupied.update(cover)
            parts.append({"id": f"p{len(parts)}", "part": number,
                          "position": [20 * cx + 10 * nx, 8 * level, 20 * cz + 10 * nz], "rotation": rotation})
            cells_of.append(None if number == "3937" else (cx, level, cz, nx, nz))  # the base has no studs
        return True

    place("3001", 0, 0, 0)
    studded = ["3001", "3001", "3003", "3010", "3020", "3022", "3004", "3710", "3034", "3023", "3002"]
    attempts = 0
    while len(parts) < n_parts and attempts < 100 * n_parts:
        attempts += 1
        i = int(rng.integers(len(parts)))
        if cells_of[i] is None:
            continue
        bcx, blevel, bcz, bnx, bnz = cells_of[i]
        roll = rng.random()
        if roll < 0.06 and n_parts - len(parts) >= 2:  # a hinge brick: base and top at one position
            cx, cz = bcx + int(rng.integers(-1, bnx)), bcz + int(rng.integers(0, bnz))
            if place("3937", cx, blevel - 3, cz):
                place("3938", cx, blevel - 3, cz, cells=False)
            continue
        if roll < 0.12 and n_parts - len(parts) >= 3:  # two technic bricks side by side, pinned
            cx, cz = bcx + int(rng.integers(-3, bnx)), bcz + int(rng.integers(-1, bnz))
            level = blevel - 3
            if place("3701", cx, level, cz, commit=False) and place("3701", cx, level, cz + 1, commit=False):
                place("3701", cx, level, cz)
                place("3701", cx, level, cz + 1)
                hole = 20 * int(rng.integers(-1, 2))
                parts.append({"id": f"p{len(parts)}", "part": "2780",
                              "position": [20 * cx + 40 + hole, 8 * level + 10, 20 * cz + 20], "rotation": ROT_Y90})
                cells_of.append(None)
            continue
        number = "3005" if roll < 0.18 else studded[int(rng.integers(len(studded)))]
        rotation = ROT_Y90 if rng.random() < 0.3 else IDENTITY
        nx, ny, nz = _footprint(number, rotation)
        cx = bcx + int(rng.integers(-(nx - 1), bnx))
        cz = bcz + int(rng.integers(-(nz - 1), bnz))
        place(number, cx, blevel - ny, cz, rotation)
    return parts


ROD_ALONG_Y = [0, -1, 0, 1, 0, 0, 0, 0, 1]  # a pin's or axle's own x axis onto y (into a beam's holes)
GEAR_ALONG_Y = [1, 0, 0, 0, 0, 1, 0, -1, 0]  # a gear's own z axis onto y
BRICK_HOLES_ALONG_Y = [0, 1, 0, 0, 0, 1, 1, 0, 0]  # a 1 x N technic brick on its side, holes along y


def gearbox(copies: int = 1, twice: bool = True) -> list[dict]:
    """Technic gearboxes side by side 80 LDU apart along x: two 7-hole beams as walls, two axles through
    both with a 24- and an 8-tooth gear in mesh, a 5-hole beam and a 1 x 4 technic brick pinned outside
    the walls with the output axle through them, a 3-long axle through a wall's end hole 5 LDU off the
    half-stud grid (it slides: it is in the hole all the same). With ``twice`` each box places one pin and the 8-tooth gear a second time at the
    same pose: the only collisions, two per box."""
    parts = []
    for k in range(copies):
        dx = 80 * k
        box = [("32524", (0, 0, 0), IDENTITY), ("32524", (0, -60, 0), IDENTITY),
               ("3706", (0, -30, -40), ROD_ALONG_Y), ("3648", (0, -30, -40), GEAR_ALONG_Y),
               ("3706", (0, -30, 0), ROD_ALONG_Y), ("3647", (0, -30, 0), GEAR_ALONG_Y),
               ("32316", (0, 20, 20), IDENTITY), ("2780", (0, 10, 40), ROD_ALONG_Y), ("2780", (0, 10, 60), ROD_ALONG_Y),
               ("3701", (-10, -80, 20), BRICK_HOLES_ALONG_Y), ("2780", (0, -70, 20), ROD_ALONG_Y),
               ("2780", (0, -70, 40), ROD_ALONG_Y), ("4519", (0, 15, -60), ROD_ALONG_Y)]
        if twice:
            box += [("2780", (0, 10, 60), ROD_ALONG_Y), ("3647", (0, -30, 0), GEAR_ALONG_Y)]
        parts += [{"id": f"g{k}p{i}", "part": number, "position": [x + dx, y, z], "rotation": list(rotation)}
                  for i, (number, (x, y, z), rotation) in enumerate(box)]
    return parts
