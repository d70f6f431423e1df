"""Progress across a solver's stages, rising smoothly: each stage owns a share of [0, 1]; inside a stage a
known count of steps moves through it evenly and an unknown count (iterations until convergence) creeps
toward its end, each tick covering a fixed part of what is left. Reports never go down, so a job's progress
bar only moves forward; every report also passes on a cancellation (the callback raises)."""

from __future__ import annotations

from plantsolve.solvers.base import Progress

CREEP = 0.15  # share of what is left of a stage that one tick of unknown count covers


class Stages:
    def __init__(self, progress: Progress) -> None:
        self._progress = progress
        self._lo, self._hi, self._message = 0.0, 0.0, ""
        self._ticks = 0
        self.last = 0.0

    def _report(self, fraction: float, message: str) -> None:
        self.last = max(self.last, min(max(fraction, 0.0), 1.0))
        self._progress(self.last, message)

    def stage(self, lo: float, hi: float, message: str) -> None:
        """Enter the stage [lo, hi): reports lo."""
        self._lo, self._hi, self._message, self._ticks = lo, hi, message, 0
        self._report(lo, message)

    def step(self, done: int, total: int, message: str | None = None) -> None:
        """``done`` of ``total`` known steps of the current stage finished."""
        f = done / total if total > 0 else 1.0
        self._report(self._lo + (self._hi - self._lo) * min(max(f, 0.0), 1.0), message or self._message)

    def tick(self, message: str | None = None) -> None:
        """One more step of a stage whose step count is not known in advance."""
        self._ticks += 1
        left = (1.0 - CREEP) ** self._ticks
        self._report(self._hi - (self._hi - self._lo) * left, message or self._message)

    def done(self, message: str = "done") -> None:
        self._report(1.0, message)
