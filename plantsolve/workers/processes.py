"""The embedded default: one process per job, forked from a warm parent that has every kind imported.

The API process never computes. Its supervisor thread hands each job to a new process forked from the
warm parent (``multiprocessing``'s forkserver, started once with every kind's modules imported), so a job
starts in milliseconds and shares the imported code with its parent instead of holding its own copy. There
is no pool to break: a process that dies (killed, out of memory, a crash in native code) ends its job's
attempt at once (:func:`plantsolve.jobs.leases.process_died`: re-queued until the attempt cap, then failed)
and the next job gets a new process; a dead warm parent is started again (its imports cost seconds, during
which ``/readyz`` says no job can start). The supervisor kills a process at its kind's hard time limit (the job
is then failed with a report). Each process runs :func:`run_job` with its own database connection, the same
claim and fencing as a Celery worker.
"""

from __future__ import annotations

import ctypes
import gc
import logging
import multiprocessing
import os
import signal
import threading
import time
import uuid
from collections import deque
from dataclasses import dataclass
from multiprocessing.connection import Connection, wait
from pathlib import Path
from typing import Iterable

from plantsolve.jobs.backoff import UNCLAIMED_RESTARTS
from plantsolve.jobs.context import ServiceContext, worker_name
from plantsolve.jobs.holds import DiskHold
from plantsolve.jobs.intake import FORKSERVER_STARTS, preload_in_forkserver
from plantsolve.jobs.leases import abandoned, process_died, remove_temporaries, resume
from plantsolve.jobs.runner import fail_killed_at_hard_limit, handed_back, run_job
from plantsolve.jobs.settings import JobSettings
from plantsolve.solvers.base import SolverSpec
from plantsolve.workers.logs import configure_logging
from plantsolve.workers.sweeper import Sweeper

log = logging.getLogger("plantsolve.processes")

# time for a solver to notice its soft limit, clean up and store a report before it is killed
HARD_LIMIT_GRACE = 5.0
# how long a stop waits for the job processes to end after the running jobs were handed back
STOP_SECONDS = 5.0
# how often the supervisor looks at the warm parent and the deadlines when no process ends meanwhile
TICK_SECONDS = 0.5
# the wait before starting a process again after a start failed (the warm parent was away)
RETRY_SECONDS = 1.0
# A job process starts in milliseconds (a fork by the warm parent); a start that has not come back in this long
# waits on a warm parent that hangs (stopped, deadlocked): it would wait forever while the service took jobs, so
# readiness says no job can start and the warm parent is killed, which ends the wait and starts a new one.
STALL_SECONDS = 10.0
# how long the ends of job processes killed with the warm parent may take to reach the supervisor (see _supervise)
WARM_DEATH_SECONDS = 0.2

_warm = multiprocessing.get_context("forkserver")


def warm_modules(kinds: Iterable[SolverSpec], plugins: Iterable[str]) -> list[str]:
    """What the warm parent imports before its first fork: this module (which limits the numeric libraries to one
    thread each before they load), the plugins, and every function of every kind."""
    modules = [__name__, "plantsolve.jobs.intake", *plugins]
    modules += [module for spec in kinds for module in spec.modules()]
    return list(dict.fromkeys(modules))


# Imported first in the warm parent (see warm_modules): its forks compute one job each, side by side with the API
# process, so each numeric library may use one thread.
for _name in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")


# glibc's mallopt parameters: arrays above the mmap threshold (at most 32 MiB by default) are fresh pages on every
# allocation, faulted in and zeroed by the kernel, and freed memory above the trim threshold is given back at once.
M_TRIM_THRESHOLD, M_MMAP_THRESHOLD = -1, -3
KEEP_FREED_BELOW = 1 << 30


def _keep_freed_memory() -> None:
    """Let this job process reuse the memory it frees instead of asking the kernel for fresh zeroed pages each time:
    a large scan's solve allocates arrays of its size again and again, and at 10 M points that system time grew
    faster than the scan (tube's 10 M-point bench 18.6 -> 15.8 s, the same numbers, the same peak). A job process
    ends with its job, so what it keeps is given back then; the API process and the warm parent keep glibc's
    defaults. Without glibc (another C library) nothing is changed."""
    try:
        libc = ctypes.CDLL("libc.so.6")
        mallopt = libc.mallopt
    except (OSError, AttributeError):
        return
    mallopt(M_MMAP_THRESHOLD, ctypes.c_int(KEEP_FREED_BELOW))
    mallopt(M_TRIM_THRESHOLD, ctypes.c_int(2**31 - 1))


def _watch_parent() -> None:
    """End this job process as soon as the service that supervises it is gone: a job process nobody supervises
    must not go on and write a result after the service was killed (the job's lease lapses and the next service
    re-queues it). The parent's end of a pipe closes when it dies; a daemon thread waits for that."""
    parent = multiprocessing.parent_process()
    if parent is None:
        return

    def watch() -> None:
        wait([parent.sentinel])
        os._exit(70)

    threading.Thread(target=watch, name="parent-watch", daemon=True).start()


def _job_process(settings_json: str, job_id: str, sender: Connection) -> None:
    """One job in its own process: the outcome goes back through ``sender`` (a process that ends without sending
    one died)."""
    # the objects inherited from the warm parent are never collected here: a collection would write to their
    # pages and copy them into this process
    gc.freeze()
    _keep_freed_memory()
    _watch_parent()
    settings = JobSettings.model_validate_json(settings_json)
    configure_logging(settings.log_format, settings.log_level)
    ctx = ServiceContext.create(settings)
    try:
        requeued: list[str] = []
        # A solver must never slow down the API process that shares this machine with it: yielded from the claim on
        # (before it, at the API's priority, so that a job starts at once on a busy machine).
        outcome = run_job(ctx, uuid.UUID(job_id), worker=worker_name("process"), hard_limit_in_thread=False,
                          requeue=lambda jid, kind="": requeued.append(str(jid)),
                          on_claim=lambda: os.nice(settings.job_niceness))
    finally:
        ctx.close()
    sender.send("requeued" if requeued else outcome)


def _parent_pid(sender: Connection) -> None:
    """A fork that says which process it was forked from: the warm parent, once its imports are done."""
    sender.send(os.getppid())


def _stat(pid: int) -> list[str] | None:
    """The fields of ``/proc/<pid>/stat`` after the command name (state first, parent pid second), or None when
    ``pid`` is gone."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except (OSError, IndexError):
        return None


def _stopped(pid: int | None) -> bool:
    """Whether process ``pid`` is stopped (SIGSTOP, or a tracer holds it): it forks nothing until it is continued."""
    fields = _stat(pid) if pid is not None else None
    return fields is not None and fields[0] in ("T", "t")


def _started(pid: int) -> str | None:
    """When running process ``pid`` started (clock ticks since boot), None when it does not run: with its pid this
    names one process, so a pid freed and reused by an unrelated process is never taken for it."""
    fields = _stat(pid)
    return fields[19] if fields is not None and fields[0] not in ("Z", "X") else None


def is_warm_parent(pid: int) -> bool:
    """Whether ``pid`` is a running forkserver of this process. Until this process reaps its dead child the pid
    cannot be reused; once reaped, the parent and command line tell an unrelated process from it."""
    fields = _stat(pid)
    if fields is None or fields[0] in ("Z", "X") or int(fields[1]) != os.getpid():
        return False
    try:
        argv = Path(f"/proc/{pid}/cmdline").read_bytes().split(b"\0")
    except OSError:
        return False
    return any(arg.startswith(b"from multiprocessing.forkserver import main") for arg in argv)


def _warm_parents() -> list[int]:
    """This process's running forkservers: the one a start waits on may have been started by that very start (the
    known one had died unnoticed), so it is found among this process's children rather than remembered."""
    pids = [int(entry.name) for entry in Path("/proc").iterdir() if entry.name.isdigit()]
    return [pid for pid in pids if is_warm_parent(pid)]


@dataclass
class _Running:
    job_id: uuid.UUID
    process: multiprocessing.process.BaseProcess
    receiver: Connection
    worker: str
    deadline: float | None
    started: str | None  # see _started: read right after the start, while the process is surely this job's
    began: float  # monotonic
    warm: int | None  # the warm parent it was forked from: it reports the process's exit status
    kind: str = ""  # its job's kind, when known
    killed_at_limit: bool = False
    abandoned: bool = False  # killed because its attempt had ended (see jobs.leases.abandoned)

    def kill(self) -> None:
        """Kill this job's process by its pid. ``process.kill()`` would not do: once the warm parent died, the
        process's multiprocessing sentinel is at its end, ``process`` believes it ended (exit code 255) and kills
        nothing while the job runs on."""
        if self.started is not None and _started(self.process.pid) == self.started:
            try:
                os.kill(self.process.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass


class ProcessDispatcher:
    """Job ids go to processes forked from the warm parent, at most ``EMBEDDED_WORKERS`` at once."""

    in_process = True  # enqueue hands the id over in memory and returns at once

    def __init__(self, ctx: ServiceContext, workers: int | None = None):
        self.ctx = ctx
        self.size = workers or ctx.settings.embedded_workers
        # Jobs held in memory (running or next in line). The database is this dispatcher's queue: beyond the window a
        # job stays queued in its row and is pulled when a process frees up, so a backlog of thousands costs the API
        # process no memory.
        self.window = max(4, 2 * self.size)
        self._running: dict[uuid.UUID, _Running] = {}
        self._waiting: deque[tuple[uuid.UUID, str]] = deque()
        self._starting: uuid.UUID | None = None  # taken from the line, its process not started yet
        # A job whose process died before it claimed the job goes back in line after the pause UNCLAIMED_RESTARTS gives
        # its deaths in a row (at once the first time).
        self._unclaimed: dict[uuid.UUID, int] = {}  # job -> its processes that died before the claim, in a row
        self._later: dict[uuid.UUID, tuple[float, str]] = {}  # job -> when it goes back in line (monotonic), its kind
        self._lock = threading.Lock()
        self._wake_r, self._wake_w = os.pipe()
        os.set_blocking(self._wake_w, False)
        self._stopping = threading.Event()
        self._thread: threading.Thread | None = None
        self._start_watch: threading.Thread | None = None
        self._warm_parent: int | None = None  # its pid once a fork has come back from it
        self._warm_start = FORKSERVER_STARTS.current()  # the forkserver start it is (see ForkserverStarts.failed)
        self._warm_since = 0.0  # when it came up (monotonic)
        self._start_failed: str | None = None
        self._start_began: float | None = None  # when the start of a job process under way began (monotonic)
        # Whether a job may wait in its row beyond the window: set when an enqueue found the window full, cleared by a
        # refill that found no more. A finished job refills from the database only then; the sweeper's pass refills
        # regardless (jobs queued by another process, or re-queued by the sweep itself).
        self._overflow = True
        self._sweeper = Sweeper(ctx, self.enqueue, self.pending, after_pass=self._after_sweep, gone=self.orphan_gone)
        self._disk = DiskHold(ctx)
        settings = JobSettings.model_validate(ctx.settings.model_dump(include=set(JobSettings.model_fields)))
        self._settings_json = settings.model_dump_json()
        # before anything starts the forkserver (the upload readers share it, adding theirs): it imports all a job needs,
        # this module first (see warm_modules) even when an upload reader's list was set before
        preload_in_forkserver(warm_modules(ctx.kinds.values(), ctx.settings.plugins), first=True)

    # ---- the dispatcher protocol ----------------------------------------------------------------

    def start(self) -> None:
        self._stopping.clear()
        self._thread = threading.Thread(target=self._supervise, name="job-supervisor", daemon=True)
        self._thread.start()
        self._start_watch = threading.Thread(target=self._watch_starts, name="job-start-watch", daemon=True)
        self._start_watch.start()
        resume(self.ctx, self.enqueue, self.pending, gone=self.orphan_gone)
        self._sweeper.start()

    def stop(self) -> None:
        """Drain: stop taking jobs, hand the running ones back to the queue (their attempt not counted: the service
        stopped, the job did not fail), then end their processes (within ``STOP_SECONDS``). Jobs waiting for a
        process stay queued in the database; the next start resumes them all."""
        self._stopping.set()
        self._sweeper.stop()
        self._wake()
        if self._thread is not None:
            self._thread.join(timeout=STOP_SECONDS)
            self._thread = None
        # joined, so that a start right after this stop does not leave two watchers
        if self._start_watch is not None:
            self._start_watch.join(timeout=STOP_SECONDS)
            self._start_watch = None
        with self._lock:
            running = list(self._running.values())
            self._running.clear()
            self._waiting.clear()
            self._later.clear()
            self._unclaimed.clear()
        for child in running:
            try:
                handed_back(self.ctx, child.job_id)
            except Exception:  # the database is away: the lease lapses and the next start re-queues it
                log.warning("job %s: could not be handed back at stop", child.job_id, exc_info=True)
        for child in running:
            child.kill()
        until = time.monotonic() + STOP_SECONDS
        for child in running:
            child.process.join(max(0.0, until - time.monotonic()))
            child.receiver.close()

    def ping(self) -> None:
        """Raises when no job can start now: the supervisor is not running, or the warm parent is not (yet) up."""
        if self._thread is None or not self._thread.is_alive():
            raise RuntimeError("the job supervisor is not running")
        if self._warm_parent is None and FORKSERVER_STARTS.pause_left() > 0:
            raise RuntimeError(f"the job processes' warm parent failed {FORKSERVER_STARTS.failures} start(s) in a row; "
                               f"the next in {FORKSERVER_STARTS.pause_left():.0f} s")
        if self._warm_parent is None or not is_warm_parent(self._warm_parent):
            raise RuntimeError("the job processes' warm parent is starting")
        if self._start_failed is not None:
            raise RuntimeError(f"job processes cannot be started: {self._start_failed}")
        if self._start_stalled():
            raise RuntimeError("starting a job process hangs: the warm parent does not answer")
        if _stopped(self._warm_parent):
            raise RuntimeError("the job processes' warm parent is stopped: no job process can start")

    def orphan_gone(self, worker: str | None) -> bool:
        """Whether ``worker`` is a job process of this host that no longer runs and that this dispatcher does not
        supervise: one of a service that was killed (its job processes die with it) and started again, whose attempt
        would otherwise show running until its lease lapsed. The ends of this dispatcher's own processes are the
        supervisor's to judge (it knows a kill at the hard limit from a crash). A pid reused since is taken for
        alive: that job waits for its lease, as before."""
        pid = job_process_pid(worker)
        if pid is None or _started(pid) is not None:
            return False
        with self._lock:
            return all(child.worker != worker for child in self._running.values())

    def in_flight(self) -> int:
        """Jobs running or next in line in memory (at most ``window``)."""
        with self._lock:
            return len(self._held())

    def _held(self) -> set[uuid.UUID]:
        """The jobs in hand (under the lock): running, starting, next in line."""
        return {*self._running, *(j for j, _ in self._waiting), *([self._starting] if self._starting else []),
                *self._later}

    def running(self) -> dict[uuid.UUID, int]:
        """The process id of each running job."""
        with self._lock:
            return {job_id: child.process.pid for job_id, child in self._running.items()}

    def pending(self) -> int:
        """Queued jobs this dispatcher holds: all of them, since it pulls them from the database."""
        return self.ctx.repo.count_queued()

    def enqueue(self, job_id: uuid.UUID, kind: str = "") -> None:
        if self._thread is None or self._stopping.is_set():
            raise RuntimeError("the job supervisor is not running")
        with self._lock:
            held = self._held()
            if job_id in held:
                return  # in hand already
            if len(held) >= self.window:
                self._overflow = True
                return  # waiting in its row until a process frees up (_refill)
            self._waiting.append((job_id, kind))
        self._wake()

    # ---- the supervisor thread -----------------------------------------------------------------

    def _wake(self) -> None:
        try:
            os.write(self._wake_w, b"x")
        except BlockingIOError:  # a wake-up is pending already
            pass

    def _supervise(self) -> None:
        while not self._stopping.is_set():
            try:
                if self._warm_parent is None and FORKSERVER_STARTS.pause_left() == 0:
                    # the ends of job processes killed with the warm parent are judged before the seconds of its start
                    # (its death makes multiprocessing's exit status of theirs unknown; judged after, a lapsed lease
                    # had often taken their attempts first)
                    self._reap_killed_with_warm_parent()
                    self._warm_up()
                self._back_in_line()
                self._launch()
                with self._lock:
                    dues = [due for due, _ in self._later.values()]
                if self._warm_parent is None:
                    dues.append(time.monotonic() + FORKSERVER_STARTS.pause_left())
                timeout = TICK_SECONDS if self._start_failed is None else RETRY_SECONDS
                ended = self._reap(min([timeout, *(max(0.05, due - time.monotonic()) for due in dues)]))
                self._enforce_deadlines()
                if self._warm_parent is not None and not is_warm_parent(self._warm_parent):
                    self._warm_died()
                if ended:
                    self._refill()
            except Exception:  # the supervisor must survive anything
                log.exception("job supervisor error")
                self._stopping.wait(RETRY_SECONDS)

    def _reap_killed_with_warm_parent(self) -> None:
        """Judge the ends of the job processes that died with the warm parent, as they come, until none runs or
        ``WARM_DEATH_SECONDS`` passed: an enqueue's wake-up meanwhile does not end the wait (it had left them to be
        judged after the warm parent's start, their exit status lost)."""
        until = time.monotonic() + WARM_DEATH_SECONDS
        while self._running and (left := until - time.monotonic()) > 0:
            self._reap(left, woken=False)

    def _reap(self, timeout: float, *, woken: bool = True) -> int:
        """Wait up to ``timeout`` for a job process's end (or, when ``woken``, a wake-up) and judge the ends; returns
        how many."""
        with self._lock:
            watched = {child.receiver: child for child in self._running.values()}
        ready = wait([*watched, *([self._wake_r] if woken else [])], timeout=timeout)
        if self._wake_r in ready:
            os.read(self._wake_r, 4096)
        ended = [watched[r] for r in ready if r in watched]
        for child in ended:
            self._ended(child)
        return len(ended)

    def _back_in_line(self) -> None:
        """Put the jobs whose pause is over (see ``_unclaimed``) back at the end of the line."""
        now = time.monotonic()
        with self._lock:
            due = [(job_id, kind) for job_id, (when, kind) in self._later.items() if when <= now]
            for job_id, kind in due:
                del self._later[job_id]
                self._waiting.append((job_id, kind))

    def _warm_up(self) -> None:
        """Fork once from the warm parent (starting it, which imports every kind, when it is not running) and
        learn its pid: from then on a job starts in milliseconds. A start that fails is tried again later
        (:class:`~plantsolve.jobs.intake.ForkserverStarts`)."""
        started = time.monotonic()
        forkserver_start = FORKSERVER_STARTS.current()
        receiver, sender = _warm.Pipe(duplex=False)
        try:
            probe = _warm.Process(target=_parent_pid, args=(sender,), daemon=True, name="warm-probe")
            probe.start()
            sender.close()
            self._warm_parent = receiver.recv()
            self._warm_start = forkserver_start
            probe.join(5)
            self._start_failed = None
            self._warm_since = time.monotonic()
            log.info("job processes ready: warm parent %d up in %.1f s", self._warm_parent, time.monotonic() - started)
        except Exception as error:
            self._start_failed = type(error).__name__
            self._warm_failed(f"could not be started ({error})", forkserver_start)
        finally:
            sender.close()
            receiver.close()

    def _warm_died(self) -> None:
        self._warm_parent = None
        self._warm_failed(f"died {time.monotonic() - self._warm_since:.1f} s after it came up", self._warm_start)

    def _warm_failed(self, what: str, forkserver_start: int) -> None:
        """A failed start of the warm parent, or its death: started again at once the first time, after a pause that
        doubles with each failure in a row after that (:class:`~plantsolve.jobs.intake.ForkserverStarts`); the jobs
        stay queued meanwhile and readiness says no job can start."""
        pause = FORKSERVER_STARTS.failed(forkserver_start)
        log.error("the job processes' warm parent %s (%d time(s) in a row); %s", what, FORKSERVER_STARTS.failures,
                  f"the next start in {pause:g} s, queued jobs waiting" if pause else "starting it again")

    def _launch(self) -> None:
        """Start a process for each job next in line while fewer than ``size`` run. A job is recorded as running
        only once its process started; one whose start failed goes back to the head of the line. None starts while
        the disk is below its floor (:class:`~plantsolve.jobs.holds.DiskHold`: the jobs stay queued, saying why)."""
        while not self._stopping.is_set():
            with self._lock:
                if len(self._running) >= self.size or not self._waiting:
                    return
            if self._warm_parent is None:
                return  # its start would start the warm parent, before its pause (see _warm_failed)
            if self._disk.holds():
                return
            with self._lock:
                if not self._waiting:
                    return
                job_id, kind = self._waiting.popleft()
                self._starting = job_id
            spec = self.ctx.spec(kind) if kind else None
            if spec is None:
                job = self.ctx.repo.get(job_id, brief=True)
                spec = self.ctx.spec(job.kind) if job is not None else None
            receiver, sender = _warm.Pipe(duplex=False)
            try:
                process = _warm.Process(target=_job_process, daemon=True, name=f"job-{job_id}",
                                        args=(self._settings_json, str(job_id), sender))
                self._start_began = time.monotonic()
                try:
                    process.start()
                finally:
                    self._start_began = None
            except Exception as error:
                receiver.close()
                with self._lock:
                    self._waiting.appendleft((job_id, kind))
                    self._starting = None
                self._start_failed = type(error).__name__
                log.error("job %s: its process could not be started (%s); trying again", job_id, error)
                return
            finally:
                sender.close()
            self._start_failed = None
            deadline = time.monotonic() + self.ctx.limits(spec)[1] + HARD_LIMIT_GRACE if spec is not None else None
            with self._lock:
                self._running[job_id] = _Running(job_id, process, receiver, worker_of(process.pid), deadline,
                                                 _started(process.pid), time.monotonic(), self._warm_parent,
                                                 spec.kind if spec is not None else kind)
                self._starting = None

    def _start_stalled(self) -> bool:
        began = self._start_began
        return began is not None and time.monotonic() - began > STALL_SECONDS

    def _watch_starts(self) -> None:
        """Kill a warm parent that leaves a job process's start waiting (see ``STALL_SECONDS``), or that has been
        stopped (SIGSTOP) that long while idle, so that the next job need not wait for it: a start under way then
        fails, its job goes back to the head of the line, and the supervisor starts a new warm parent. Meanwhile
        readiness says no job can start (:meth:`ping`)."""
        stopped_since: float | None = None
        while not self._stopping.wait(TICK_SECONDS):
            warm = self._warm_parent
            stopped_since = (stopped_since or time.monotonic()) if warm is not None and _stopped(warm) else None
            idle_stopped = stopped_since is not None and time.monotonic() - stopped_since > STALL_SECONDS
            if not (self._start_stalled() or idle_stopped):
                continue
            why = "it has been stopped" if idle_stopped else "a job process's start has waited on it"
            stopped_since = None
            for warm in _warm_parents():
                log.error("the warm parent %d does not answer (%s for more than %.0f s): killing it", warm, why,
                          STALL_SECONDS)
                try:
                    os.kill(warm, signal.SIGKILL)
                except ProcessLookupError:
                    pass

    def _ended(self, child: _Running) -> None:
        try:
            outcome = child.receiver.recv()
        except (EOFError, OSError):
            outcome = None  # it died without a word
        child.receiver.close()
        child.process.join(1.0)
        if child.process.exitcode is None:
            child.process.kill()
            child.process.join(1.0)
        try:
            again = self._judge_end(child, outcome)
        finally:
            # only now: until its end is written, the sweeper leaves this process's attempt to the supervisor
            with self._lock:
                self._running.pop(child.job_id, None)
        if again:
            self.enqueue(child.job_id)

    def _died_unclaimed(self, job_id: uuid.UUID, kind: str, deaths: int) -> bool:
        """``job_id``'s process died before it claimed the job, after ``deaths`` such deaths in a row: whether it goes
        back in line now (the first time in a row), or after a pause (see ``_unclaimed``)."""
        deaths = self._unclaimed[job_id] = deaths + 1
        pause = UNCLAIMED_RESTARTS.pause(deaths)
        if not pause:
            log.error("job %s: its process died before it could claim the job; it starts again", job_id)
            return True
        with self._lock:
            self._later[job_id] = (time.monotonic() + pause, kind)
        log.error("job %s: its process died before it could claim the job, %d times in a row; it starts again in "
                  "%.0f s (no attempt counted)", job_id, deaths, pause)
        return False

    def _judge_end(self, child: _Running, outcome: str | None) -> bool:
        """Write how ``child``'s attempt ended, when its process did not (killed at the hard limit, died); returns
        whether its job goes back in line."""
        deaths = self._unclaimed.pop(child.job_id, 0)  # kept again only by another death before the claim
        if outcome is None:
            try:
                remove_temporaries(self.ctx, child.job_id, child.process.pid)
            except Exception:  # best effort: a folder that cannot be read keeps them, the job goes on
                log.warning("job %s: the temporary files of its dead process could not be removed", child.job_id,
                            exc_info=True)
        if self._stopping.is_set():
            return False
        if child.killed_at_limit:
            if fail_killed_at_hard_limit(self.ctx, child.job_id, worker=child.worker):
                log.warning("job %s killed at its hard time limit", child.job_id)
            return False
        if outcome is None:
            exitcode = child.process.exitcode
            if exitcode == 255 and (child.warm is None or not is_warm_parent(child.warm)):
                # multiprocessing's stand-in when the warm parent that reports a job process's end died first (killed
                # with it, say): the job process's own status is not known, and was most often a signal, not 255
                exitcode = None
            fate = process_died(self.ctx, child.job_id, child.worker, exitcode)
            if child.abandoned:
                # killed here after the sweep took its attempt back (queued again, counted): not a death before the
                # claim, whatever the row says now
                return fate in ("requeued", "queued")
            if fate == "queued":
                return self._died_unclaimed(child.job_id, child.kind, deaths)
            log.error("job %s: its process died (exit code %s); the job is %s", child.job_id,
                      "unknown" if exitcode is None else exitcode, fate)
            return fate == "requeued"
        return outcome == "requeued"

    def _enforce_deadlines(self) -> None:
        now = time.monotonic()
        with self._lock:
            overdue = [c for c in self._running.values() if c.deadline is not None and now > c.deadline
                       and not c.killed_at_limit]
        for child in overdue:
            child.killed_at_limit = True
            child.kill()

    def _after_sweep(self) -> None:
        self._kill_abandoned()
        self._refill(always=True)

    def _kill_abandoned(self) -> None:
        """Kill each job process whose attempt has ended while it ran on (:func:`plantsolve.jobs.leases.abandoned`: a
        process stopped or hung past its lease, whose job the sweep has just given back): its job then starts again in
        a new process now, not at the old one's hard time limit, and its place in the pool is free."""
        with self._lock:
            children = [c for c in self._running.values() if not (c.killed_at_limit or c.abandoned)]
        now = time.monotonic()
        for child in children:
            if abandoned(self.ctx, child.job_id, child.worker, now - child.began):
                log.error("job %s: its process %d holds no live attempt any more (stopped or hung past its lease); "
                          "killing it", child.job_id, child.process.pid)
                child.abandoned = True
                child.kill()

    def _refill(self, always: bool = False) -> None:
        """Take the oldest queued jobs into the window until it is full again (after a finished job only when some
        may be waiting beyond the window: see ``_overflow``)."""
        with self._lock:
            held = self._held()
            free = self.window - len(held)
            if free <= 0 or self._stopping.is_set() or not (always or self._overflow):
                return
            # cleared before the read: an enqueue that overflows after it sets it again (its row is committed before
            # the enqueue, so a read after the clear sees it either way)
            self._overflow = False
        try:
            # one more than fits: whether more wait than this refill takes
            waiting = [(j, kind) for j, kind in self.ctx.repo.queued_jobs(limit=free + len(held) + 1) if j not in held]
            if len(waiting) > free:
                self._overflow = True
            for job_id, kind in waiting[:free]:
                self.enqueue(job_id, kind)
        except Exception:  # the database is away (or the dispatcher is stopping): the next pass refills
            self._overflow = True
            if not self._stopping.is_set():
                log.warning("refilling the job processes failed", exc_info=True)


def worker_of(pid: int) -> str:
    """The worker name job process ``pid`` gives itself (:func:`plantsolve.jobs.context.worker_name`)."""
    return worker_name("process", pid)


def job_process_pid(worker: str | None) -> int | None:
    """The pid of the job process of this host named ``worker`` (:func:`worker_of`); None for another host's, or
    another transport's worker or another pid namespace's (a container of the same host name). Host names are unique
    among the hosts sharing a database (as Celery's node names)."""
    prefix = worker_of(0)[:-1]
    if worker is None or not worker.startswith(prefix) or not worker[len(prefix):].isdigit():
        return None
    return int(worker[len(prefix):])
