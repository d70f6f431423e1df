"""Faces as flat arrays: the embedding the generalized map is built on.

Every loop of every face is a run of vertex indices in one array (``loop_vertices``), loops in
face order, so a face's boundary positions are contiguous and per-face sums are one
``np.add.reduceat``. A *use* is a face bounding one zone: a face between two zones has two
uses, the second with the loops read backwards (``use_sign = -1``). Subsurfaces have no use.

What the stages derive from the loops (next positions, uses, edge-uses and their grouping by
edge) is computed once per value and kept on it, so repair, the generalized map and the
diagnostics share one sort of the edges; a repair that changes the loops makes a new value.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field, replace
from functools import cached_property
from itertools import chain

import numpy as np

from plantsolve.schemas.polyhedra import PolyhedraRequest
from plantsolve.solvers.polyhedra.edges import EdgeGroups, group_edges

DEFAULT_ZONE = "default"


class FaceIds(Sequence):
    """Face ids: the named faces, then ``count`` numbered ones ``<prefix>1``, ``<prefix>2``, … (a mesh's
    triangles), made when asked rather than a million strings up front."""

    def __init__(self, names: Sequence[str], prefix: str = "t", count: int = 0):
        self.names, self.prefix, self.count = list(names), prefix, int(count)

    def __len__(self) -> int:
        return len(self.names) + self.count

    def __getitem__(self, i):
        if isinstance(i, slice):
            return [self[k] for k in range(*i.indices(len(self)))]
        i = int(i)
        n = len(self.names)
        if i < 0:
            i += len(self)
        if 0 <= i < n:
            return self.names[i]
        if n <= i < len(self):
            return f"{self.prefix}{i - n + 1}"
        raise IndexError(i)

    def __iter__(self) -> Iterator[str]:
        return chain(self.names, (f"{self.prefix}{k}" for k in range(1, self.count + 1)))

    def __eq__(self, other) -> bool:
        return isinstance(other, Sequence) and len(other) == len(self) and all(a == b for a, b in zip(self, other))

    __hash__ = None  # type: ignore[assignment]


def _frozen(array: np.ndarray) -> np.ndarray:
    array.setflags(write=False)  # shared by every stage: none may edit another's input
    return array


@dataclass(frozen=True)
class Polygons:
    points: np.ndarray  # (N, 3) float
    loop_vertices: np.ndarray  # (M,) int, every loop's vertex indices, loops in face order
    loop_start: np.ndarray  # (L + 1,) offsets into loop_vertices
    loop_face: np.ndarray  # (L,) face of each loop, non-decreasing
    face_ids: Sequence[str]
    face_zone: np.ndarray  # (F, 2) zone indices, -1 where none (a subsurface has none, most faces one)
    face_parent: np.ndarray  # (F,) host face index, -1 for an enclosure face
    zone_ids: list[str]
    face_loop_start: np.ndarray = field(init=False)  # (F + 1,) first loop of each face

    def __post_init__(self) -> None:
        n_faces = len(self.face_ids)
        object.__setattr__(self, "face_loop_start", np.searchsorted(self.loop_face, np.arange(n_faces + 1)))

    @property
    def face_zones(self) -> list[tuple[int, ...]]:
        return [tuple(int(z) for z in row if z >= 0) for row in self.face_zone]

    @property
    def n_faces(self) -> int:
        return len(self.face_ids)

    @property
    def loop_lengths(self) -> np.ndarray:
        return np.diff(self.loop_start)

    @cached_property
    def position_loop(self) -> np.ndarray:
        """The loop of each position of ``loop_vertices``."""
        return _frozen(np.repeat(np.arange(len(self.loop_start) - 1), self.loop_lengths))

    @cached_property
    def position_face(self) -> np.ndarray:
        return _frozen(self.loop_face[self.position_loop])

    @property
    def face_position_start(self) -> np.ndarray:
        """(F + 1,) offsets: the positions of face f are face_position_start[f]:face_position_start[f + 1]."""
        return self.loop_start[self.face_loop_start]

    def next_position(self) -> np.ndarray:
        """The position after each position along its loop (the last wraps to the first)."""
        return self._next_position

    @cached_property
    def _next_position(self) -> np.ndarray:
        nxt = np.arange(1, len(self.loop_vertices) + 1)
        ends = self.loop_start[1:] - 1
        nxt[ends] = self.loop_start[:-1]
        return _frozen(nxt)

    def with_loops(self, loop_vertices: np.ndarray, loop_start: np.ndarray) -> Polygons:
        return replace(self, loop_vertices=np.asarray(loop_vertices, dtype=np.int64),
                       loop_start=np.asarray(loop_start, dtype=np.int64))

    def uses(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(face, zone, sign) of every use, faces in order, a face's first zone first."""
        return self._uses

    @cached_property
    def _uses(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        has = self.face_zone >= 0  # row-major: a face's first zone comes before its second
        if has[:, 0].all() and not has[:, 1].any():  # one use per face (a mesh, a building without party walls)
            n = self.n_faces
            return _frozen(np.arange(n)), _frozen(self.face_zone[:, 0].copy()), _frozen(np.ones(n, dtype=np.int64))
        face, column = np.nonzero(has)
        return _frozen(face), _frozen(self.face_zone[has]), _frozen(np.where(column == 0, 1, -1))

    @cached_property
    def edge_uses(self) -> tuple[np.ndarray, np.ndarray]:
        """(position, use) of every edge-use, as :func:`expand_uses` gives them for every use."""
        position, use = expand_uses(self, self.uses()[0])
        return _frozen(position), _frozen(use)

    @cached_property
    def edge_groups(self) -> EdgeGroups:
        """The edge-uses grouped by (zone, undirected edge): sorted once, shared by every stage."""
        position, use = self.edge_uses
        a = self.loop_vertices[position]
        b = self.loop_vertices[self.next_position()[position]]
        use_zone = self.uses()[1]
        if len(self.zone_ids) == 1:  # one zone: a view of zeros, not an array of them
            zone = np.broadcast_to(np.zeros(1, dtype=use_zone.dtype), (len(use),))
        else:
            zone = use_zone[use]
        return group_edges(a, b, zone, len(self.points), len(self.zone_ids))


def expand_uses(poly: Polygons, use_face: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Edge-uses: for each use, each boundary position of its face. Returns (position, use) arrays,
    ordered by use, so a use's edge-uses are contiguous and aligned with its face's positions."""
    starts = poly.face_position_start
    if len(use_face) == poly.n_faces and np.array_equal(use_face, np.arange(poly.n_faces)):
        # one use per face, in face order: the edge-uses are the positions themselves
        return np.arange(len(poly.loop_vertices)), poly.position_face
    lengths = (starts[1:] - starts[:-1])[use_face]
    use = np.repeat(np.arange(len(use_face)), lengths)
    offsets = np.cumsum(lengths) - lengths
    position = np.arange(int(lengths.sum())) - np.repeat(offsets, lengths) + np.repeat(starts[use_face], lengths)
    return position, use


def from_request(request: PolyhedraRequest) -> Polygons:
    """Flat arrays from a validated request: point loops become vertices appended after the given ones."""
    given = np.asarray(request.vertices, dtype=float).reshape(-1, 3)
    extra: list[list[float]] = []  # points of point loops, appended after the given vertices
    n_points = len(given)
    flat: list = []
    lengths: list[int] = []
    loop_face: list[int] = []
    zone_index: dict[str, int] = {}
    face_zones: list[tuple[int, int]] = []
    index = {face.id: i for i, face in enumerate(request.faces)}
    parents = np.full(len(request.faces), -1, dtype=np.int64)
    for i, face in enumerate(request.faces):
        for loop in face.loops:
            if loop and isinstance(loop[0], list):
                extra.extend(loop)
                flat.append(range(n_points, n_points + len(loop)))
                n_points += len(loop)
            else:
                flat.append(loop)
            lengths.append(len(loop))
            loop_face.append(i)
        if face.parent is not None:
            parents[i] = index[face.parent]
            face_zones.append((-1, -1))
        else:
            zs = [zone_index.setdefault(z, len(zone_index)) for z in (face.zones or [DEFAULT_ZONE])]
            face_zones.append((zs[0], zs[1] if len(zs) > 1 else -1))
    loop_start = np.zeros(len(lengths) + 1, dtype=np.int64)
    np.cumsum(lengths, out=loop_start[1:])
    vertices = np.fromiter((v for loop in flat for v in loop), dtype=np.int64, count=int(loop_start[-1]))
    points = np.concatenate([given, np.asarray(extra, dtype=float).reshape(-1, 3)]) if extra else given
    face_zone = np.asarray(face_zones, dtype=np.int64).reshape(-1, 2)
    loop_face_array = np.asarray(loop_face, dtype=np.int64)
    names = [f.id for f in request.faces]
    mesh = request.mesh
    if mesh is None:
        return Polygons(points=points, loop_vertices=vertices, loop_start=loop_start, loop_face=loop_face_array,
                        face_ids=names, face_zone=face_zone, face_parent=parents, zone_ids=list(zone_index))
    # the mesh's triangles follow the faces: its vertices after theirs, its faces numbered after theirs
    zone = zone_index.setdefault(mesh.zone, len(zone_index))
    n = len(mesh.triangles)
    n_named = len(names)
    return Polygons(
        points=np.concatenate([points, mesh.vertices]) if len(points) else mesh.vertices,
        loop_vertices=np.concatenate([vertices, (mesh.triangles + len(points)).reshape(-1)]),
        loop_start=np.concatenate([loop_start, loop_start[-1] + np.arange(3, 3 * n + 1, 3, dtype=np.int64)]),
        loop_face=np.concatenate([loop_face_array, np.arange(n_named, n_named + n, dtype=np.int64)]),
        face_ids=FaceIds(names, mesh.id_prefix, n),
        face_zone=np.concatenate([face_zone, np.column_stack([np.full(n, zone), np.full(n, -1)])]),
        face_parent=np.concatenate([parents, np.full(n, -1, dtype=np.int64)]), zone_ids=list(zone_index))


def from_mesh(vertices: np.ndarray, triangles: np.ndarray, zone: str = DEFAULT_ZONE, prefix: str = "T") -> Polygons:
    """A triangle mesh (one zone) as flat arrays, without a request in between."""
    triangles = np.asarray(triangles, dtype=np.int64)
    n = len(triangles)
    return Polygons(points=np.asarray(vertices, dtype=float), loop_vertices=triangles.reshape(-1),
                    loop_start=np.arange(0, 3 * n + 1, 3, dtype=np.int64), loop_face=np.arange(n, dtype=np.int64),
                    face_ids=FaceIds([], prefix, n),
                    face_zone=np.column_stack([np.zeros(n, dtype=np.int64), np.full(n, -1)]),
                    face_parent=np.full(n, -1, dtype=np.int64), zone_ids=[zone])
