"""The small runtime contract between a solver and whoever runs it.

A solver receives a :class:`Progress` callback. It calls ``progress(fraction, message)``
between iterations; the callback raises :class:`Cancelled` when the job has been
cancelled (or its time is up), so a solver needs no extra code to honour cancellation
beyond calling it regularly.

Errors a solver may raise:
- :class:`InputRejected` — the input is invalid in a way only the solver can see
  (e.g. a pipe whose ports are not collinear). The service answers 422 naming the field.
- :class:`SolverError` — the solver could not produce any result. A solver that merely
  did not converge must *not* raise: it returns its best result with a report instead.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Protocol, Sequence


class Progress(Protocol):
    def __call__(self, fraction: float, message: str = "") -> None:
        """Report progress in [0, 1]; raises :class:`Cancelled` if the run must stop."""


def no_progress(fraction: float, message: str = "") -> None:
    """A :class:`Progress` that ignores reports and never cancels (library and test use)."""


class Cancelled(Exception):
    """Raised by the progress callback when the job was cancelled or timed out."""


@dataclass
class FieldError:
    """One bad field: ``loc`` is the JSON path (e.g. ``("connections", 3, "to")``)."""

    loc: tuple[str | int, ...]
    msg: str
    type: str = "value_error"


class InputRejected(ValueError):
    """The input is invalid; carries one :class:`FieldError` per bad field."""

    def __init__(self, errors: Sequence[FieldError] | FieldError, title: str | None = None):
        self.errors = [errors] if isinstance(errors, FieldError) else list(errors)
        self.title = title or "; ".join(
            f"{'/'.join(str(p) for p in e.loc) or '(body)'}: {e.msg}" for e in self.errors
        )
        super().__init__(self.title)


class SolverError(Exception):
    """The solver produced no usable result.

    ``stage`` names the stage that failed, ``message`` is a human sentence, ``details`` is
    JSON-serialisable and machine readable.
    """

    def __init__(self, stage: str, message: str, details: dict[str, Any] | None = None):
        self.stage = stage
        self.message = message
        self.details = details or {}
        super().__init__(f"{stage}: {message}")


@dataclass
class Artifact:
    """A file produced from a result: a plot, a mesh, an exported model."""

    name: str  # file name, e.g. "tube.stl"; unique per job
    media_type: str  # e.g. "model/stl", "image/png"
    data: bytes = field(repr=False)
