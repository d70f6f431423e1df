"""Why a part or a piece stands apart: the nearest connection point of the rest of the model that would fit one of its
own and how far it misses (the drawing's own gap), and the parts not in the catalogue lying beside it.

A piece that the matching (within rounding) and :meth:`Assembly.join_pieces` (a slip of up to 3 LDU) left apart is
either joined through a part the catalogue does not know (an embedded custom part, a hose segment), or its drawing
places no joint: its nearest mate is further off than a slip (a row of plates a plate's height off the studs it
would sit on, hinge fingers a knuckle's diameter apart), or none lies near at all. The warnings name both, so that a
reader can tell which.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy.spatial import cKDTree

from plantsolve.solvers.rigidity.catalogue import ANY_DIRECTION, FITS, OPPOSED, mate

REACH = 40.0  # LDU: points further apart than this (two stud pitches) are no near miss
TURN = np.cos(np.radians(30.0))  # |cos| of the angle between two points' directions within which they are a miss
NEIGHBOURS = 8  # points of a mating type compared with each point of the piece, nearest first (then directions)
UNKNOWN_REACH = 60.0  # LDU: parts not in the catalogue whose origin lies this close to a part's origin are named


class Misses:
    """Nearest misses between the parts of an assembly (the points of each part computed once, runs as points along
    them, without snap cylinders, whose start points say nothing of a gap)."""

    def __init__(self, assembly) -> None:
        self.parts = assembly.parts
        self.ids = list(self.parts)
        self.index = {p: k for k, p in enumerate(self.ids)}
        self._points: dict[str, tuple[list[str], np.ndarray, np.ndarray]] = {}
        self._codes: dict[str, int] = {}
        boxes = [(p.rotation @ np.asarray(p.shape.box_center, float) + p.position,
                  float(np.linalg.norm(np.asarray(p.shape.box_size, float))) / 2) for p in self.parts.values()]
        self.centres = np.array([c for c, _ in boxes]).reshape(-1, 3)
        self.radii = np.array([r for _, r in boxes])

    def _sampled(self, pid: str) -> tuple[list[str], np.ndarray, np.ndarray]:
        """(types, world points, world directions) of the part's connection points, a run (an axle, a bar, hinge
        fingers) as a point every LDU along it, both ends included."""
        if pid not in self._points:
            placed = self.parts[pid]
            types, points, directions = [], [], []
            for k, c in enumerate(placed.shape.connectors):
                if c.type in FITS:
                    continue
                steps = np.linspace(0.0, c.length, int(np.ceil(c.length)) + 1) if c.length > 0 else np.zeros(1)
                types.extend([c.type] * len(steps))
                points.append(placed.points[k] + np.outer(steps, placed.directions[k]))
                directions.extend([placed.directions[k]] * len(steps))
            self._points[pid] = (types, np.concatenate(points) if points else np.zeros((0, 3)),
                                 np.array(directions, float).reshape(-1, 3))
        return self._points[pid]

    def _points_of(self, ids) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(type codes, points, directions, owner index into ``ids``) of the connection points of ``ids``."""
        codes, points, directions, owners = [], [], [], []
        for k, pid in enumerate(ids):
            types, p, d = self._sampled(pid)
            codes.extend(self._code(t) for t in types)
            points.append(p)
            directions.append(d)
            owners.extend([k] * len(types))
        if not codes:
            return np.zeros(0, int), np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0, int)
        return np.array(codes), np.concatenate(points), np.concatenate(directions), np.array(owners)

    def _code(self, kind: str) -> int:
        if kind not in self._codes:
            self._codes[kind] = len(self._codes)
        return self._codes[kind]

    def _compatible(self) -> tuple[np.ndarray, np.ndarray]:
        """For every pair of type codes: whether they mate (a ring only holds the studs around it: no miss), and
        whether their directions must be opposed (studs) or may be any (a ball)."""
        kinds = sorted(self._codes, key=self._codes.get)
        n = len(kinds)
        fits, how = np.zeros((n, n), bool), np.zeros((n, n), int)  # how: 0 parallel, 1 opposed, 2 any
        for a in kinds:
            for b in kinds:
                kind = mate(a, b)
                if kind is not None and kind != "ring":
                    fits[self._codes[a], self._codes[b]] = True
                    how[self._codes[a], self._codes[b]] = 2 if kind in ANY_DIRECTION else int(kind in OPPOSED)
        return fits, how

    def nearest(self, piece: Sequence[str]) -> dict | None:
        """The closest pair of connection points of compatible types, one of a part of ``piece`` and one of a part
        outside it: ``{"part", "number", "type", "other", "other_number", "other_type", "gap_ldu", "sideways_ldu"}``
        (``sideways_ldu``: how far the other point lies off the line of this one's direction); None when no such pair
        lies within REACH."""
        members = [self.index[p] for p in piece]
        inside = np.zeros(len(self.ids), bool)
        inside[members] = True
        lo = (self.centres[members] - self.radii[members, None]).min(axis=0) - REACH
        hi = (self.centres[members] + self.radii[members, None]).max(axis=0) + REACH
        near = ~inside & np.all((self.centres + self.radii[:, None] >= lo) & (self.centres - self.radii[:, None] <= hi),
                                axis=1)
        others = [self.ids[j] for j in np.nonzero(near)[0]]
        mine = list(piece)
        m_codes, m_points, m_dirs, m_owner = self._points_of(mine)
        o_codes, o_points, o_dirs, o_owner = self._points_of(others)
        if not len(m_codes) or not len(o_codes):
            return None
        fits, how = self._compatible()
        best = None  # (gap, mine point, other point)
        for code in np.unique(m_codes):  # each type of the piece's points against the points of the types it mates
            rows, columns = np.nonzero(m_codes == code)[0], np.nonzero(fits[code, o_codes])[0]
            if not len(columns):
                continue
            k = min(NEIGHBOURS, len(columns))
            gaps, found = cKDTree(o_points[columns]).query(m_points[rows], k=k, distance_upper_bound=REACH)
            gaps, found = gaps.reshape(len(rows), k), found.reshape(len(rows), k)
            ok = np.isfinite(gaps)
            other = columns[np.where(ok, found, 0)]
            cos = np.einsum("ij,ikj->ik", m_dirs[rows], o_dirs[other])
            way = how[code, o_codes[other]]
            ok &= (way == 2) | ((way == 1) & (-cos >= TURN)) | ((way == 0) & (np.abs(cos) >= TURN))
            if ok.any():
                i, j = np.unravel_index(np.argmin(np.where(ok, gaps, np.inf)), gaps.shape)
                if best is None or gaps[i, j] < best[0]:
                    best = (float(gaps[i, j]), rows[i], other[i, j])
        if best is None:
            return None
        gap, i, j = best
        pid, oid = mine[m_owner[i]], others[o_owner[j]]
        kinds = sorted(self._codes, key=self._codes.get)
        offset = o_points[j] - m_points[i]
        sideways = float(np.linalg.norm(offset - np.dot(offset, m_dirs[i]) * m_dirs[i]))
        return {"part": pid, "number": self.parts[pid].number, "type": kinds[m_codes[i]], "other": oid,
                "other_number": self.parts[oid].number, "other_type": kinds[o_codes[j]], "gap_ldu": round(gap, 2),
                "sideways_ldu": round(sideways, 2)}


def unknown_near(piece: Sequence[str], positions: dict[str, np.ndarray], unknown: Sequence[str]) -> list[str]:
    """The parts not in the catalogue (ids) whose origin lies within UNKNOWN_REACH of the origin of a part of
    ``piece``: the piece may be held by one of them."""
    if not unknown or not piece:
        return []
    mine = np.array([positions[p] for p in piece])
    return [u for u in unknown if float(np.min(np.linalg.norm(mine - positions[u], axis=1))) <= UNKNOWN_REACH]
