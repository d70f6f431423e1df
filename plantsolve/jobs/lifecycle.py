"""A job's lifecycle in one place: its statuses and the transitions between them.

::

    queued ──claim──▶ running ──succeed──▶ succeeded
      ▲  │              │  │ ──fail──────▶ failed
      │  │              │  └─(lease lapsed)─ claim again, or requeue / fail by the sweeper
      │  └──cancel──┐   │
      └──requeue────┼───┘
                    ▼
                cancelled  ◀──cancel── running

Every status write of the store is one of the transitions below (``CLAIM`` … ``CANCEL``): the repository takes a
transition's ``sources`` for its conditional update (``WHERE status IN sources``) and its
``target`` for the new value, so a status can only change along an arrow drawn here. The
runner, the sweeper, the views and the event streams read :func:`is_finished` from here too.
"""

from __future__ import annotations

from dataclasses import dataclass

from plantsolve.schemas.jobs import JobStatus

QUEUED, RUNNING, SUCCEEDED, FAILED, CANCELLED = (
    JobStatus.QUEUED, JobStatus.RUNNING, JobStatus.SUCCEEDED, JobStatus.FAILED, JobStatus.CANCELLED)

STATUSES: tuple[JobStatus, ...] = tuple(JobStatus)
FINISHED: tuple[JobStatus, ...] = (SUCCEEDED, FAILED, CANCELLED)
ACTIVE: tuple[JobStatus, ...] = (QUEUED, RUNNING)


@dataclass(frozen=True)
class Transition:
    """One arrow: from any of ``sources`` to ``target``."""

    name: str
    sources: tuple[JobStatus, ...]
    target: JobStatus


# a running job is claimed again only when its lease lapsed (the repository adds that condition)
CLAIM = Transition("claim", (QUEUED, RUNNING), RUNNING)
SUCCEED = Transition("succeed", (RUNNING,), SUCCEEDED)
FAIL = Transition("fail", (RUNNING,), FAILED)
REQUEUE = Transition("requeue", (RUNNING,), QUEUED)
CANCEL = Transition("cancel", (QUEUED, RUNNING), CANCELLED)


def is_finished(status: str) -> bool:
    """True for a status no transition leaves."""
    return status in FINISHED
