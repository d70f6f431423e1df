"""How long to wait before trying again something that failed several times in a row: a one-off failure is tried
again at once, a repeated one ever later, so a cause that lasts (a process killed at every start, a library that
crashes at import) costs a few tries a minute, not hundreds."""

from __future__ import annotations

from dataclasses import dataclass

# beyond this many doublings every pause is the longest anyway; the float of 2 ** 1024 would overflow
_MOST_DOUBLINGS = 60


@dataclass(frozen=True)
class Backoff:
    """No pause after the first failure in a row, ``first`` seconds after the second, then twice as long after each
    one more, up to ``longest`` seconds."""

    first: float
    longest: float

    def pause(self, failures: int) -> float:
        """Seconds to wait after ``failures`` failures in a row."""
        if failures <= 1:
            return 0.0
        return min(self.first * 2.0 ** min(failures - 2, _MOST_DOUBLINGS), self.longest)


# A job whose process died before it claimed the job (nothing of it ran, no attempt counted) goes back in line after
# this pause: a process killed at every start (a watchdog, the out-of-memory killer, a database job processes cannot
# open) was otherwise started again at once, hundreds of times a minute, for as long as the cause lasted.
UNCLAIMED_RESTARTS = Backoff(first=1.0, longest=30.0)
# The forkserver that job and upload-reading processes fork from, when it fails its start or dies
# (plantsolve.jobs.intake.ForkserverStarts): each start imports every kind.
FORKSERVER_RESTARTS = Backoff(first=1.0, longest=30.0)
