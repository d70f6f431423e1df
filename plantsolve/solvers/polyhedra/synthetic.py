"""Shapes with known answers (request bodies), the small ``example()``, and generators of multi-zone
buildings and large closed triangle meshes for the benchmark."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

CUBE_VERTICES = [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]]
# counter-clockwise seen from outside: bottom, top, south, east, north, west
CUBE_LOOPS = [[0, 3, 2, 1], [4, 5, 6, 7], [0, 1, 5, 4], [1, 2, 6, 5], [2, 3, 7, 6], [3, 0, 4, 7]]
CUBE_NAMES = ["floor", "roof", "south", "east", "north", "west"]


def box_faces(lo, hi, zone: str | None = None, prefix: str = "") -> list[dict]:
    """The six faces of an axis-aligned box as point loops, counter-clockwise seen from outside."""
    lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
    corners = lo + (hi - lo) * np.asarray(CUBE_VERTICES, dtype=float)
    faces = []
    for name, loop in zip(CUBE_NAMES, CUBE_LOOPS):
        face = {"id": f"{prefix}{name}", "loops": [corners[loop].tolist()]}
        if zone is not None:
            face["zones"] = [zone]
        faces.append(face)
    return faces


def unit_cube(offset=(0.0, 0.0, 0.0), rotation: Rotation | None = None, scale: float = 1.0) -> dict:
    """The unit cube (volume 1, area 6), optionally scaled, rotated about its corner, then moved."""
    v = np.asarray(CUBE_VERTICES, dtype=float) * scale
    if rotation is not None:
        v = rotation.apply(v)
    v = v + np.asarray(offset, dtype=float)
    return {"units": "m", "vertices": v.tolist(),
            "faces": [{"id": n, "loops": [loop]} for n, loop in zip(CUBE_NAMES, CUBE_LOOPS)]}


def block_with_hole() -> dict:
    """A 3 x 3 x 1 block with a 1 x 1 through hole in the middle: volume 8, area 32, genus 1. Top and
    bottom are faces with an inner loop."""
    outer = [[0, 0], [3, 0], [3, 3], [0, 3]]
    inner = [[1, 1], [2, 1], [2, 2], [1, 2]]
    v = [[x, y, z] for z in (0, 1) for x, y in outer + inner]  # 0-3 outer bottom, 4-7 inner bottom, 8.. top

    def at(k, top):
        return k + (8 if top else 0)

    faces = [
        {"id": "top", "loops": [[at(0, 1), at(1, 1), at(2, 1), at(3, 1)], [at(4, 1), at(7, 1), at(6, 1), at(5, 1)]]},
        {"id": "bottom", "loops": [[at(0, 0), at(3, 0), at(2, 0), at(1, 0)], [at(4, 0), at(5, 0), at(6, 0), at(7, 0)]]},
    ]
    for k in range(4):
        a, b = k, (k + 1) % 4
        faces.append({"id": f"outer{k}", "loops": [[at(a, 0), at(b, 0), at(b, 1), at(a, 1)]]})
        ia, ib = 4 + k, 4 + (k + 1) % 4
        faces.append({"id": f"shaft{k}", "loops": [[at(ib, 0), at(ia, 0), at(ia, 1), at(ib, 1)]]})
    return {"units": "m", "vertices": v, "faces": faces}


def t_junction_cube() -> dict:
    """The unit cube with its south wall split in two at x = 0.5 while floor and roof stay whole."""
    body = unit_cube()
    body["vertices"] += [[0.5, 0, 0], [0.5, 0, 1]]
    faces = [f for f in body["faces"] if f["id"] != "south"]
    faces += [{"id": "south-1", "loops": [[0, 8, 9, 4]]}, {"id": "south-2", "loops": [[8, 1, 5, 9]]}]
    body["faces"] = faces
    return body


def inside_out_cube() -> dict:
    body = unit_cube()
    for face in body["faces"]:
        face["loops"] = [loop[::-1] for loop in face["loops"]]
    return body


def open_box() -> dict:
    """The unit cube without its roof: four open edges around the top."""
    body = unit_cube()
    body["faces"] = [f for f in body["faces"] if f["id"] != "roof"]
    return body


def two_zones_sharing_a_wall() -> dict:
    """Two unit cubes side by side along x; the wall x = 1 is one face of both (counter-clockwise seen from
    outside Z1, i.e. seen from Z2)."""
    faces = [f for f in box_faces((0, 0, 0), (1, 1, 1), "Z1", "Z1-") if f["id"] != "Z1-east"]
    faces += [f for f in box_faces((1, 0, 0), (2, 1, 1), "Z2", "Z2-") if f["id"] != "Z2-west"]
    faces.append({"id": "party-wall", "loops": [[[1, 0, 0], [1, 1, 0], [1, 1, 1], [1, 0, 1]]], "zones": ["Z1", "Z2"]})
    return {"units": "m", "faces": faces}


def cubes_sharing_an_edge() -> dict:
    """Two unit cubes of one zone touching along the edge x = 1, y = 1: a non-manifold edge; volume 2."""
    faces = box_faces((0, 0, 0), (1, 1, 1), None, "a-") + box_faces((1, 1, 0), (2, 2, 1), None, "b-")
    return {"units": "m", "faces": faces}


def wall_with_window() -> dict:
    """The unit cube with a 0.4 x 0.5 window in its south wall (a subsurface)."""
    body = unit_cube()
    body["faces"].append({"id": "window", "parent": "south",
                          "loops": [[[0.3, 0, 0.3], [0.7, 0, 0.3], [0.7, 0, 0.8], [0.3, 0, 0.8]]]})
    return body


def gable_house(width: float = 8.0, depth: float = 10.0, eave: float = 3.0, ridge: float = 5.0) -> dict:
    """A gable house: walls to ``eave``, two roof slopes to ``ridge`` along y; the roof slopes carry extra
    collinear vertices on their eave and ridge edges that the walls and gables do not have.
    Volume width·depth·eave + width·(ridge − eave)·depth/2."""
    w, d, e, r = width, depth, eave, ridge
    faces = [
        {"id": "floor", "loops": [[[0, 0, 0], [0, d, 0], [w, d, 0], [w, 0, 0]]]},
        {"id": "wall-west", "loops": [[[0, 0, 0], [0, 0, e], [0, d, e], [0, d, 0]]]},
        {"id": "wall-east", "loops": [[[w, 0, 0], [w, d, 0], [w, d, e], [w, 0, e]]]},
        {"id": "gable-south", "loops": [[[0, 0, 0], [w, 0, 0], [w, 0, e], [w / 2, 0, r], [0, 0, e]]]},
        {"id": "gable-north", "loops": [[[0, d, 0], [0, d, e], [w / 2, d, r], [w, d, e], [w, d, 0]]]},
        {"id": "roof-west", "loops": [[[0, 0, e], [w / 2, 0, r], [w / 2, d / 2, r], [w / 2, d, r], [0, d, e],
                                       [0, 2 * d / 3, e], [0, d / 3, e]]]},
        {"id": "roof-east", "loops": [[[w, 0, e], [w, d / 4, e], [w, d, e], [w / 2, d, r], [w / 2, 0, r]]]},
    ]
    return {"units": "m", "faces": faces}


def building(floors: int, rooms_x: int, rooms_y: int, room: tuple[float, float, float] = (5.0, 4.0, 3.0),
             windows: bool = True, origin=(0.0, 0.0, 0.0), panels: int = 1) -> dict:
    """A block of ``floors × rooms_x × rooms_y`` box rooms on a shared vertex grid: interior walls and
    slabs are one face with two zones, exterior walls carry a window subsurface each. Every room has
    the volume ``room[0] · room[1] · room[2]``. With ``panels`` > 1 every wall and slab is split into
    ``panels × panels`` faces (as cladding and ceiling grids are modelled; neighbours split alike, so
    the surfaces stay conforming) and the window sits in the middle half of the panel at (1, 1)."""
    nx, ny, nz = rooms_x + 1, rooms_y + 1, floors + 1
    gx, gy, gz = np.meshgrid(np.arange(nx) * room[0], np.arange(ny) * room[1], np.arange(nz) * room[2], indexing="ij")
    vertices = (np.stack([gx, gy, gz], axis=-1).reshape(-1, 3) + np.asarray(origin, dtype=float)).tolist()

    def vid(i, j, k):
        return (i * ny + j) * nz + k

    def zone(i, j, k):
        return f"F{k + 1}-R{i + 1}-{j + 1}"

    faces: list[dict] = []
    # faces normal to z (slabs): counter-clockwise seen from below the slab (outside the zone below)
    for k in range(nz):
        for i in range(rooms_x):
            for j in range(rooms_y):
                below = [zone(i, j, k - 1)] if k > 0 else []
                above = [zone(i, j, k)] if k < floors else []
                loop = [vid(i, j, k), vid(i + 1, j, k), vid(i + 1, j + 1, k), vid(i, j + 1, k)]
                if below:  # counter-clockwise seen from above = outside the zone below
                    faces.append({"id": f"slab-{i}-{j}-{k}", "loops": [loop], "zones": below + above})
                else:
                    faces.append({"id": f"slab-{i}-{j}-{k}", "loops": [loop[::-1]], "zones": above})
    for k in range(floors):
        for i in range(nx):  # walls normal to x, counter-clockwise seen from +x
            for j in range(rooms_y):
                west = [zone(i - 1, j, k)] if i > 0 else []
                east = [zone(i, j, k)] if i < rooms_x else []
                loop = [vid(i, j, k), vid(i, j + 1, k), vid(i, j + 1, k + 1), vid(i, j, k + 1)]
                fid = f"wx-{i}-{j}-{k}"
                faces.append({"id": fid, "loops": [loop if west else loop[::-1]], "zones": west + east})
                if windows and not (west and east):
                    x = i * room[0] + origin[0]
                    y0, z0 = j * room[1] + origin[1], k * room[2] + origin[2]
                    pts = [[x, y0 + 1, z0 + 1], [x, y0 + 2, z0 + 1], [x, y0 + 2, z0 + 2], [x, y0 + 1, z0 + 2]]
                    faces.append({"id": f"win-{fid}", "parent": fid, "loops": [pts if west else pts[::-1]]})
        for j in range(ny):  # walls normal to y, counter-clockwise seen from +y
            for i in range(rooms_x):
                south = [zone(i, j - 1, k)] if j > 0 else []
                north = [zone(i, j, k)] if j < rooms_y else []
                loop = [vid(i, j, k), vid(i, j, k + 1), vid(i + 1, j, k + 1), vid(i + 1, j, k)]
                fid = f"wy-{i}-{j}-{k}"
                faces.append({"id": fid, "loops": [loop if south else loop[::-1]], "zones": south + north})
                if windows and not (south and north):
                    y = j * room[1] + origin[1]
                    x0, z0 = i * room[0] + origin[0], k * room[2] + origin[2]
                    pts = [[x0 + 1, y, z0 + 1], [x0 + 1, y, z0 + 2], [x0 + 2, y, z0 + 2], [x0 + 2, y, z0 + 1]]
                    faces.append({"id": f"win-{fid}", "parent": fid, "loops": [pts if south else pts[::-1]]})
    if panels > 1:
        faces = _split_into_panels(faces, np.asarray(vertices), panels)
    return {"units": "m", "vertices": vertices, "faces": faces}


def _split_into_panels(faces: list[dict], vertices: np.ndarray, k: int) -> list[dict]:
    out = []
    t = np.linspace(0.0, 1.0, k + 1)
    for face in faces:
        if face.get("parent"):
            continue
        a, b, c, d = (vertices[i] for i in face["loops"][0])

        def at(u, v):
            return (1 - u) * (1 - v) * a + u * (1 - v) * b + u * v * c + (1 - u) * v * d

        for i in range(k):
            for j in range(k):
                loop = [at(t[i], t[j]), at(t[i + 1], t[j]), at(t[i + 1], t[j + 1]), at(t[i], t[j + 1])]
                out.append({**face, "id": f"{face['id']}.{i}.{j}", "loops": [[p.tolist() for p in loop]]})
        if any(f.get("parent") == face["id"] for f in faces):
            u0, u1, v0, v1 = t[1] + (t[2] - t[1]) / 4, t[2] - (t[2] - t[1]) / 4, t[1] + (t[2] - t[1]) / 4, t[2] - (t[2] - t[1]) / 4
            loop = [at(u0, v0), at(u1, v0), at(u1, v1), at(u0, v1)]
            out.append({"id": f"win-{face['id']}", "parent": f"{face['id']}.1.1", "loops": [[p.tolist() for p in loop]]})
    return out


def torus_mesh(n_major: int, n_minor: int, major: float = 3.0, minor: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """A closed, outward-oriented triangle mesh of a torus: ``2 · n_major · n_minor`` triangles."""
    u = np.arange(n_major) * 2 * np.pi / n_major
    v = np.arange(n_minor) * 2 * np.pi / n_minor
    uu, vv = np.meshgrid(u, v, indexing="ij")
    ring = major + minor * np.cos(vv)
    vertices = np.stack([ring * np.cos(uu), ring * np.sin(uu), minor * np.sin(vv)], axis=-1).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(n_major), np.arange(n_minor), indexing="ij")
    a = i * n_minor + j
    b = ((i + 1) % n_major) * n_minor + j
    c = ((i + 1) % n_major) * n_minor + (j + 1) % n_minor
    d = i * n_minor + (j + 1) % n_minor
    triangles = np.concatenate([np.stack([a, b, c], -1).reshape(-1, 3), np.stack([a, c, d], -1).reshape(-1, 3)])
    return vertices, triangles


def example() -> dict:
    """Two rooms sharing a wall, one with a window: a request that solves in milliseconds."""
    body = two_zones_sharing_a_wall()
    body["faces"].append({"id": "Z1-window", "parent": "Z1-south",
                          "loops": [[[0.25, 0.0, 0.25], [0.75, 0.0, 0.25], [0.75, 0.0, 0.75], [0.25, 0.0, 0.75]]]})
    body["options"] = {"merge_tolerance": 1e-6, "planarity_tolerance": 1e-4}
    return body
