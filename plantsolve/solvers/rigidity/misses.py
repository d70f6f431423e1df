"""Why a part or a piece stands apart: the nearest connection point of the rest of the model that would fit one of its
own and how far it misses (the drawing's own gap), and the parts not in the catalogue lying beside it.

A piece that the matching (within rounding) and :meth:`Assembly.join_pieces` (a slip of up to 3 LDU) left apart is
either joined through a part the catalogue does not know (an embedded custom part, a hose segment), or its drawing
places no joint: its nearest mate is further off than a slip (a brick resting on the tips of studs 4 LDU up, hinge
arms drawn 5.8 LDU off each other's axis), or none lies near at all. The warnings name both, so that a reader can
tell which.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from plantsolve.solvers.rigidity.catalogue import ANY_DIRECTION, OPPOSED, mate

REACH = 40.0  # LDU: points further apart than this (two stud pitches) are no near miss
TURN = np.cos(np.radians(30.0))  # |cos| of the angle between two points' directions within which they are a miss
UNKNOWN_REACH = 60.0  # LDU: parts not in the catalogue whose origin lies this close to a part's origin are named


class Misses:
    """Nearest misses between the parts of an assembly (the points of each part computed once, runs as points along
    them: :meth:`PartShape.sampled`, without snap cylinders, whose start points say nothing of a gap)."""

    def __init__(self, assembly) -> None:
        self.parts = assembly.parts
        self.ids = list(self.parts)
        self.index = {p: k for k, p in enumerate(self.ids)}
        self._points: dict[str, tuple[list[str], np.ndarray, np.ndarray]] = {}
        self._mates: dict[tuple[str, str], str | None] = {}
        boxes = [(p.rotation @ np.asarray(p.shape.box_center, float) + p.position,
                  float(np.linalg.norm(np.asarray(p.shape.box_size, float))) / 2) for p in self.parts.values()]
        self.centres = np.array([c for c, _ in boxes]).reshape(-1, 3)
        self.radii = np.array([r for _, r in boxes])

    def _sampled(self, pid: str) -> tuple[list[str], np.ndarray, np.ndarray]:
        if pid not in self._points:
            placed = self.parts[pid]
            shape = placed.shape.sampled()
            directions = np.array([c.direction for c in shape.connectors], float).reshape(-1, 3) @ placed.rotation.T
            self._points[pid] = ([c.type for c in shape.connectors],
                                 shape.points() @ placed.rotation.T + placed.position, directions)
        return self._points[pid]

    def _fits(self, a: str, b: str, cos: float) -> bool:
        """Types that mate, their directions within TURN of the way they meet (opposed studs and anti-studs)."""
        if (a, b) not in self._mates:
            self._mates[(a, b)] = mate(a, b)
        kind = self._mates[(a, b)]
        if kind is None or kind == "ring":
            return False
        return kind in ANY_DIRECTION or (-cos if kind in OPPOSED else abs(cos)) >= TURN

    def nearest(self, piece: Sequence[str]) -> dict | None:
        """The closest pair of connection points of compatible types, one of a part of ``piece`` and one of a part
        outside it: ``{"part", "number", "type", "other", "other_number", "other_type", "gap_ldu"}``; None when no
        such pair lies within REACH."""
        inside = np.zeros(len(self.ids), bool)
        inside[[self.index[p] for p in piece]] = True
        best = None
        for pid in piece:
            k = self.index[pid]
            near = np.nonzero(~inside & (np.linalg.norm(self.centres - self.centres[k], axis=1)
                                         <= REACH + self.radii + self.radii[k]))[0]
            mine_types, mine_points, mine_directions = self._sampled(pid)
            if not mine_types:
                continue
            for j in near:
                oid = self.ids[j]
                other_types, other_points, other_directions = self._sampled(oid)
                if not other_types:
                    continue
                gaps = np.linalg.norm(mine_points[:, None, :] - other_points[None, :, :], axis=2)
                for a, b in zip(*np.nonzero(gaps <= (REACH if best is None else best[0]))):
                    cos = float(mine_directions[a] @ other_directions[b])
                    if self._fits(mine_types[a], other_types[b], cos) and (best is None or gaps[a, b] < best[0]):
                        best = (float(gaps[a, b]), pid, mine_types[a], oid, other_types[b])
        if best is None:
            return None
        gap, pid, kind, oid, other_kind = best
        return {"part": pid, "number": self.parts[pid].number, "type": kind, "other": oid,
                "other_number": self.parts[oid].number, "other_type": other_kind, "gap_ldu": round(gap, 2)}


def unknown_near(piece: Sequence[str], positions: dict[str, np.ndarray], unknown: Sequence[str]) -> list[str]:
    """The parts not in the catalogue (ids) whose origin lies within UNKNOWN_REACH of the origin of a part of
    ``piece``: the piece may be held by one of them."""
    if not unknown or not piece:
        return []
    mine = np.array([positions[p] for p in piece])
    return [u for u in unknown if float(np.min(np.linalg.norm(mine - positions[u], axis=1))) <= UNKNOWN_REACH]
