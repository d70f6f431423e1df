"""How an attempt ends: the retry policy (:func:`judge`: what an error means for the job) and the job's one attempt
history (:func:`ended`: the entry each attempt leaves, made here and nowhere else).

The history is the job's ``attempts`` column, a list of :class:`AttemptEntry` (the job's view shows it as it is);
a failure report, a typed :class:`Report`, says what went wrong in words and carries no history of its own.
"""

from __future__ import annotations

import errno
import re
import uuid
from dataclasses import dataclass
from datetime import datetime
from typing import Any

from pydantic import BaseModel, ValidationError

from plantsolve.jobs.errors import is_infrastructure_failure, user_path
from plantsolve.schemas.common import Report
from plantsolve.schemas.jobs import AttemptInfo as AttemptEntry
from plantsolve.solvers.base import Cancelled, InputRejected, SolverError
from plantsolve.store.models import utcnow

__all__ = ["AttemptEntry", "Report", "Stop", "ResultPending", "Verdict", "judge", "ended", "failure_report", "clean"]


class Stop(Cancelled):
    """Raised inside the solver (through the progress callback) to end the attempt."""

    def __init__(self, reason: str):
        self.reason = reason  # "cancelled" (or lost lease) | "time_limit"
        super().__init__(reason)


class ResultPending(ConnectionError):
    """A computed result the database did not take in time: it waits in the blob store (or, when that is
    away too, in this machine's spool folder) for the next attempt. ``solved_here``: the attempt that spooled it
    solved it (False: it stored an earlier attempt's spooled or kept result, and failed to)."""

    def __init__(self, message: str, *, solved_here: bool = True):
        super().__init__(message)
        self.solved_here = solved_here


def failure_report(stage: str, message: str, **details: Any) -> dict:
    return Report(status="failed", stage=stage, message=message, details=details).model_dump(mode="json")


_PATHS = re.compile(r"(?:[A-Za-z]:)?(?:[\\/][\w.@+-]+){2,}")


def clean(error: BaseException) -> str:
    """The error's message for a client: one line, server paths removed, at most 300 characters."""
    text = " ".join(str(error).split())
    return _PATHS.sub("<path>", text)[:300]


@dataclass(frozen=True)
class Verdict:
    """What becomes of a job whose attempt ended with an error: its attempt entry's ``outcome`` and ``error``, the
    job's ``report``, and whether it goes back to the queue (``retry``, with one more attempt granted when
    ``grant_attempt``) or ends failed. ``outcome`` "cancelled": the job was cancelled (or another attempt holds it):
    nothing to write."""

    outcome: str
    report: dict | None = None
    error: str | None = None
    retry: bool = False
    grant_attempt: bool = False
    crash: bool = False  # an error no rule names: its traceback belongs in the server log


def judge(error: Exception, *, job_id: uuid.UUID, attempt: int, max_attempts: int, limits: tuple[float, float],
          elapsed: float, time_limit_errors: tuple[type[BaseException], ...] = (),
          model: type[BaseModel] | None = None) -> Verdict:
    """The retry policy. A stop asked for (cancelled, lease lost) ends the attempt quietly; the time limit, a refused
    input and a solver's own failure fail the job; a result that the database did not take is stored by the next
    attempt (granted one when this was the last); a crash of the machine's services (network, disk, database) is
    retried until the attempt cap; any other crash repeats on the same input and fails the job at once.

    ``model`` is the kind's request model: a refused input's fields are named by the paths the user wrote
    (:func:`~plantsolve.jobs.errors.user_path`), as the 422 of a submission names them."""
    if isinstance(error, Stop) and error.reason != "time_limit":
        return Verdict("cancelled")
    if isinstance(error, Stop) or isinstance(error, time_limit_errors):
        soft, hard = limits
        return Verdict("time_limit", failure_report(
            "time_limit", f"The solver ran past its time limit ({soft:g} s soft, {hard:g} s hard) and was stopped.",
            soft_time_limit=soft, time_limit=hard, elapsed_seconds=round(elapsed, 3)))
    if isinstance(error, ResultPending) and attempt >= max_attempts and not error.solved_here:
        # the attempt granted to store a waiting result could not store it either: one grant per result, or a
        # write the database always refuses in time (a result too large for its statement timeout) would re-queue
        # the job for ever
        message = (f"The result was computed but could not be stored in {attempt} attempts ({clean(error)}); "
                   "giving up.")
        return Verdict("failed", failure_report("infrastructure", message), error=clean(error))
    if isinstance(error, ResultPending):
        return Verdict("result_pending", failure_report(
            "result", "The result was computed but the database did not take it; the next attempt stores it without "
                      "solving again."), retry=True, grant_attempt=attempt >= max_attempts)
    if isinstance(error, InputRejected):
        report = failure_report("input", error.title, errors=[
            {"loc": user_path(e.loc, model), "msg": e.msg, "type": e.type} for e in error.errors])
        return Verdict("failed", report, error=report["message"])
    if isinstance(error, ValidationError):
        # only the request's own validation has the request's paths (a result that fails its model has others)
        validated = model if model is not None and error.title == model.__name__ else None
        report = failure_report("input", "The stored input no longer validates.", errors=[
            {**e, "loc": user_path(e["loc"], validated)} for e in error.errors(include_url=False, include_context=False)])
        return Verdict("failed", report, error=report["message"])
    if isinstance(error, SolverError):
        return Verdict("failed", failure_report(error.stage, error.message, **error.details), error=error.message)
    # reports say what happened in words; exception class names stay in the server log
    words = clean(error)
    said = words or "internal error"
    if isinstance(error, MemoryError):
        # an allocation the process could not make: the same input asks for the same memory again, so it is not
        # retried, and the user is told what ran out (a bare MemoryError says nothing: "internal error" did not)
        detail = f" ({words})" if words else ""
        return Verdict("failed", failure_report(
            "solver", f"The solver ran out of memory on this input{detail}; it was not retried because the same "
                      "input needs the same memory. Send a smaller input (fewer points or elements, a coarser "
                      f"resolution); the server log has the details of job {job_id}, attempt {attempt}."),
            error="out of memory", crash=True)
    if not is_infrastructure_failure(error):
        return Verdict("failed", failure_report(
            "solver", f"The solver failed on this input ({said}); it was not retried because the same input fails "
                      "the same way. Check the input's values (scale, degenerate geometry); the server log has the "
                      f"details of job {job_id}, attempt {attempt}."), error=said, crash=True)
    if disk_full(error):
        # a full disk stays full for longer than a re-queued job waits: another attempt would solve again and meet
        # it again (three solves for one failure); the result's write was already retried for RESULT_WRITE_SECONDS
        return Verdict("failed", failure_report(
            "infrastructure", f"A disk of the service is full ({said}): the job failed on the machine, not on the "
                              "input. It was not retried, since another attempt would meet the same full disk after "
                              "solving again; submit it again once space is freed (the server log has the details "
                              f"of job {job_id}).",
            disk_full=True), error=said, crash=True)
    # a disk, network or database error is the machine's, not the input's nor the solver's: said so, so that the
    # user sends the same input again once the service is back instead of looking for a fault in it; another error
    # of input and output (a file that is no gzip, one not found) may be either, and is said as such
    if attempt < max_attempts:
        return Verdict("requeued", failure_report(
            "infrastructure", f"An attempt failed on an input/output error ({said}); the job was re-queued."),
            error=said, retry=True, crash=True)
    if _the_machines(error):
        message = (f"Each of {attempt} attempts failed on the machine's services (disk, network or database), not on "
                   f"the input: {said}. Submit it again once the service is ready")
    else:
        message = (f"Each of {attempt} attempts failed on an input/output error ({said}): a service of the machine, "
                   "or a file the input names or holds that cannot be read")
    return Verdict("failed", failure_report(
        "infrastructure", f"{message} (the server log has the details of job {job_id})."), error=said, crash=True)


# errno values that are the machine's (a full or failing disk, a network that is away), whatever the input
MACHINE_ERRNOS = frozenset(getattr(errno, name) for name in (
    "ENOSPC", "EDQUOT", "EIO", "EROFS", "ENOMEM", "ESTALE", "ECONNREFUSED", "ECONNRESET", "ECONNABORTED", "ETIMEDOUT",
    "EHOSTUNREACH", "ENETUNREACH", "ENETDOWN", "EPIPE", "ENOTCONN") if hasattr(errno, name))


DISK_FULL_ERRNOS = frozenset(getattr(errno, name) for name in ("ENOSPC", "EDQUOT") if hasattr(errno, name))
SQLITE_FULL = 13  # SQLite's "database or disk is full"
POSTGRES_DISK_FULL = "53100"  # SQLSTATE disk_full


def disk_full(error: BaseException) -> bool:
    """Whether ``error``, or an error it was raised from, says a disk (or a quota) is full: an OSError of ENOSPC
    or EDQUOT, SQLite's SQLITE_FULL, PostgreSQL's disk_full."""
    seen: set[int] = set()
    while error is not None and id(error) not in seen:
        seen.add(id(error))
        if isinstance(error, OSError) and error.errno in DISK_FULL_ERRNOS:
            return True
        if getattr(error, "sqlite_errorcode", None) == SQLITE_FULL \
                or getattr(error, "sqlstate", None) == POSTGRES_DISK_FULL:
            return True
        error = getattr(error, "orig", None) or error.__cause__ or error.__context__
    return False


def _the_machines(error: BaseException) -> bool:
    """Whether an infrastructure failure is surely the machine's: a connection, a time-out, the database or broker
    away, or an OSError of a full or failing disk or an unreachable network."""
    if isinstance(error, (ConnectionError, TimeoutError)) or not isinstance(error, OSError):
        return True
    return error.errno in MACHINE_ERRNOS

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
