"""A job's one attempt history: the entry each attempt leaves when it ends, made here and nowhere else.

The history is the job's ``attempts`` column, a list of :class:`AttemptEntry` (the job's view shows it as it is);
a failure report says what went wrong in words and carries no history of its own.
"""

from __future__ import annotations

from datetime import datetime

from plantsolve.schemas.jobs import AttemptInfo as AttemptEntry
from plantsolve.store.models import utcnow

__all__ = ["AttemptEntry", "ended"]

ERROR_CHARACTERS = 300


def ended(previous: list | None, attempt: int, worker: str | None, outcome: str, *, error: str | None = None,
          started_at: datetime | None = None) -> list[dict]:
    """The history ``previous`` with attempt ``attempt``'s entry (ended now with ``outcome``) in place of any earlier
    entry of the same attempt (whose start it keeps when none is given)."""
    earlier = [h for h in (previous or []) if h.get("attempt") != attempt]
    same = next((h for h in (previous or []) if h.get("attempt") == attempt), {})
    entry = AttemptEntry(attempt=attempt, worker=worker, started_at=started_at or same.get("started_at"),
                         finished_at=utcnow(), outcome=outcome,
                         error=str(error)[:ERROR_CHARACTERS] if error else None)
    return earlier + [entry.model_dump(mode="json", exclude_none=True)]
