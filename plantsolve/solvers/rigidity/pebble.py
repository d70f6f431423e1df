"""The (6,6) pebble game for body-bar and body-hinge frameworks: the generic degrees of freedom.

Tay's theorem (body-bar) and the Tay–Whiteley theorem (body-hinge, each hinge counting as five bars
on its line) say a generic framework's constraint rank is the size of a largest (6,6)-sparse subset
of its bar multigraph; the pebble game of Jacobs–Hendrickson, in the general (k,l) form of
Lee–Streinu, finds it. Each body holds six pebbles; a bar is independent when seven pebbles can be
gathered on its two ends, and it then takes one. A joint leaving f freedoms counts as 6 − f bars
(hinge 5, cylindrical 4, ball 3, planar 3, slider 5 — a slider is a hinge at infinity, rigid 6).

The count is exact for bars and hinges (the theorems above). Ball, planar, slider and cylindrical joints
enter as their number of constraint rows; their rows are not generic bars (a ball's three forces
meet in a point), so for them the count bounds the generic rank from above: two bodies on two ball
joints count as rigid but turn about the line through the balls in every position, and the exact
pass then reports ``special_position``.

The game is incremental on insertion: :meth:`PebbleGame.add_joint` costs a few searches of the
directed graph near the new bar. Deletion is not supported (rebuild: the game is linear in practice).
"""

from __future__ import annotations

from collections import defaultdict

K = 6
L = 6


class PebbleGame:
    """Free pebbles and directed bars; ``generic_dof`` counts motions relative to each other."""

    def __init__(self) -> None:
        self.pebbles: dict = {}
        self.out: dict = defaultdict(lambda: defaultdict(int))  # out[u][v] = bars directed u -> v (> 0)
        self.independent = 0
        self.redundant = 0

    def add_body(self, body) -> None:
        if body not in self.pebbles:
            self.pebbles[body] = K

    def _find_pebble(self, start, held: set) -> bool:
        """Move one free pebble to ``start`` along a directed path avoiding ``held`` (reversing the path)."""
        parent = {start: None}
        stack = [start]
        while stack:
            x = stack.pop()
            for y in self.out[x]:
                if y in parent or y in held:
                    continue
                parent[y] = x
                if self.pebbles[y] > 0:
                    self.pebbles[y] -= 1
                    while parent[y] is not None:  # reverse each bar of the path: y now points back
                        x2 = parent[y]
                        edges = self.out[x2]
                        edges[y] -= 1
                        if not edges[y]:
                            del edges[y]  # keep only live bars: the search walks dict keys
                        self.out[y][x2] += 1
                        y = x2
                    self.pebbles[start] += 1
                    return True
                stack.append(y)
        return False

    def add_bar(self, u, v) -> bool:
        """Insert one bar; True when it is independent."""
        self.add_body(u)
        self.add_body(v)
        if u == v:
            self.redundant += 1
            return False
        held = {u, v}
        while self.pebbles[u] + self.pebbles[v] < L + 1:
            if self.pebbles[u] < K and self._find_pebble(u, held):
                continue
            if self.pebbles[v] < K and self._find_pebble(v, held):
                continue
            self.redundant += 1
            return False
        if self.pebbles[u] > 0:
            self.pebbles[u] -= 1
            self.out[u][v] += 1
        else:
            self.pebbles[v] -= 1
            self.out[v][u] += 1
        self.independent += 1
        return True

    def add_joint(self, u, v, bars: int) -> int:
        """Insert a joint as ``bars`` parallel bars; returns how many were independent. Once one bar
        between u and v is redundant the rest are too (nothing more can reach u or v): no search."""
        for k in range(bars):
            if not self.add_bar(u, v):
                self.redundant += bars - k - 1
                return k
        return bars

    @property
    def generic_dof(self) -> int:
        """Free pebbles minus the six motions of the whole model (0 bodies: 0)."""
        return max(sum(self.pebbles.values()) - L, 0) if self.pebbles else 0
