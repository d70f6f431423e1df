"""Group commit of new jobs on SQLite: one thread of the process writes every submission.

SQLite takes one writer at a time. When each submission inserts its row in its own transaction from its own
thread, concurrent submissions queue for the write lock one by one (each taking the lock, writing the WAL, and
committing), and the threads that wait compete with the event loop for the interpreter. Here submissions are
handed to one writer thread instead: it takes every submission waiting at that moment and inserts them in one
transaction (one lock, one commit for the lot), then answers each. The more submissions arrive at once, the
fewer commits per submission; a lone submission is written at once, as before.

Durability is unchanged: a submission's future is answered only after the commit that holds its row (a 202 is
never sent for a row that is not committed), and a failed transaction fails every submission in it (none is
answered as stored). A row whose idempotency key is taken makes the batch's insert fail as a whole; then each row
of the batch is inserted in a transaction of its own, so that the others are stored and the taken one answers
with the job that holds the key.

The insert is one ``executemany`` of plain SQL with the columns' own bind processors (what SQLAlchemy's compiled
insert would send, without its per-statement compilation and parameter bookkeeping, which cost more than the
write itself on this path).
"""

from __future__ import annotations

import logging
import queue
import sqlite3
import threading
import time
from concurrent.futures import Future
from contextlib import AbstractContextManager
from typing import Any, Callable

from sqlalchemy import Engine, Table
from sqlalchemy.exc import IntegrityError, OperationalError

log = logging.getLogger("plantsolve.store")

# rows one transaction takes at most: bounds how long the first submission of a large burst waits for its commit
MAX_BATCH = 64
# how long the writer thread retries at short intervals while another process holds SQLite's write lock, before
# it leaves the waiting to SQLite's busy handler (see JobWriter._write_unwaiting)
UNWAITING_PATIENCE = 0.25
SQLITE_BUSY = 5


class JobWriter:
    """Inserts job rows (complete column dicts) from one thread, in one transaction per batch of waiting rows.

    ``find_by_key(key)`` looks up the job holding an idempotency key (for a row whose key was taken); ``made(row)``
    is what a stored row is answered as."""

    def __init__(self, engine: Engine, table: Table, writing: Callable[[], AbstractContextManager],
                 find_by_key: Callable[[str], Any], made: Callable[..., Any] = dict):
        self.engine = engine
        self.made = made
        self.writing = writing
        self.find_by_key = find_by_key
        self.columns = tuple(column.key for column in table.columns)
        names = ", ".join(engine.dialect.identifier_preparer.quote(column.name) for column in table.columns)
        self.sql = f"INSERT INTO {table.name} ({names}) VALUES ({', '.join('?' for _ in table.columns)})"
        self.processors = tuple(column.type.dialect_impl(engine.dialect).bind_processor(engine.dialect)
                                for column in table.columns)
        self._queue: queue.SimpleQueue[tuple[dict, Future] | None] = queue.SimpleQueue()
        self._thread: threading.Thread | None = None
        self._start_lock = threading.Lock()
        self._unwaiting = None  # see _unwaiting_connection

    def create(self, record: dict[str, Any]) -> Future:
        """Write a row: the future answers ``(made(record), True)`` once it is committed, ``(existing job, False)``
        when its idempotency key was taken, or raises what the write raised.

        When no other write is under way or waiting, the row is written at once on the calling thread and the future
        comes back done: handing a lone row to the writer thread and back costs more than the write (two thread
        wake-ups). That write never waits: it takes the in-process write lock only if free, and its connection
        gives up at once (no busy timeout) when another process holds SQLite's; then the row goes to the writer
        thread as any other."""
        future: Future = Future()
        if self._queue.empty() and self._write_now(record):
            future.set_result((self.made(record), True))
            return future
        if self._thread is None:
            self._start()
        self._queue.put((record, future))
        return future

    def _write_now(self, record: dict[str, Any]) -> bool:
        """Insert and commit ``record`` on this thread if that needs no waiting; False (nothing written) otherwise,
        and for any error (the writer thread then writes it, or raises the error as the database gives it)."""
        lock = self.writing()
        if not lock.acquire(blocking=False):
            return False
        try:
            return self._write_unwaiting([self._row(record)], patience=0.0)
        except Exception:
            return False
        finally:
            lock.release()

    def _write_unwaiting(self, rows: list[tuple], *, patience: float) -> bool:
        """Insert and commit ``rows`` on the connection without busy timeout (the caller holds the write lock); while
        another process holds SQLite's write lock, try again after short pauses for up to ``patience`` seconds.
        SQLite's own busy handler sleeps 1, 2, 5, 10, 15 ... ms between tries, far longer than a job process's
        write holds the lock, and a submission would wait that out. False (nothing written) when the lock stays
        taken, and for any other error: the caller then writes through SQLAlchemy, which waits with the busy
        handler and raises the error as SQLAlchemy's (a taken key, an unreachable database)."""
        deadline, pause = time.monotonic() + patience, 0.0001
        while True:
            try:
                connection = self._unwaiting_connection()
                connection.cursor().executemany(self.sql, rows)
                connection.commit()
                return True
            except Exception as error:  # rolled back, so that the caller may write the rows
                try:
                    self._unwaiting.rollback()
                except Exception:
                    self._drop_unwaiting()
                busy = isinstance(error, sqlite3.OperationalError) and \
                    (getattr(error, "sqlite_errorcode", 0) & 0xFF) == SQLITE_BUSY
                if not busy or time.monotonic() + pause > deadline:
                    return False
                time.sleep(pause)
                pause = min(2 * pause, 0.001)

    def _unwaiting_connection(self):
        """The DB-API connection of :meth:`_write_now` (used under the write lock only): no busy timeout, and no
        automatic WAL checkpoint (a checkpoint writes the database file and syncs; the writer thread's connections
        and the job processes' run them)."""
        if self._unwaiting is None:
            connection = self.engine.raw_connection()
            cursor = connection.cursor()
            cursor.execute("PRAGMA busy_timeout=0")
            cursor.execute("PRAGMA wal_autocheckpoint=0")
            cursor.close()
            self._unwaiting = connection
        return self._unwaiting

    def _drop_unwaiting(self) -> None:
        connection, self._unwaiting = self._unwaiting, None
        if connection is not None:
            try:
                connection.invalidate()
            except Exception:
                pass

    def close(self) -> None:
        """Write what is queued, then end the thread (a later :meth:`create` starts another)."""
        with self._start_lock:
            thread, self._thread = self._thread, None
        if thread is not None:
            self._queue.put(None)
            thread.join()
        leftover = []  # queued by a create that saw the old thread just before it ended
        while True:
            try:
                item = self._queue.get_nowait()
            except queue.Empty:
                break
            if item is not None:
                leftover.append(item)
        if leftover:
            self._write(leftover)
        try:
            with self.writing():
                self._release_unwaiting()
        except OperationalError:  # the database is away (its file was removed): no write can use the connection now
            self._release_unwaiting()

    def _release_unwaiting(self) -> None:
        if self._unwaiting is not None:
            self._unwaiting.close()  # back to the pool
            self._unwaiting = None

    def _start(self) -> None:
        with self._start_lock:
            if self._thread is None:
                self._thread = threading.Thread(target=self._run, name="job-writer", daemon=True)
                self._thread.start()

    def _run(self) -> None:
        while True:
            item = self._queue.get()
            stop = item is None
            batch = [] if stop else [item]
            while len(batch) < MAX_BATCH:
                try:
                    item = self._queue.get_nowait()
                except queue.Empty:
                    break
                if item is None:
                    stop = True
                else:
                    batch.append(item)
            if batch:
                self._write(batch)
            if stop:
                return

    def _write(self, batch: list[tuple[dict, Future]]) -> None:
        batch = [(record, future) for record, future in batch if future.set_running_or_notify_cancel()]
        try:
            rows = [self._row(record) for record, _ in batch]
            with self.writing():
                if not self._write_unwaiting(rows, patience=UNWAITING_PATIENCE):
                    with self.engine.begin() as connection:  # SQLite's busy handler waits; errors as SQLAlchemy's
                        connection.exec_driver_sql(self.sql, rows)
        except IntegrityError:
            self._write_one_by_one(batch)
            return
        except BaseException as error:
            for _, future in batch:
                future.set_exception(error)
            return
        for record, future in batch:
            future.set_result((self.made(record), True))

    def _write_one_by_one(self, batch: list[tuple[dict, Future]]) -> None:
        """Each row in its own transaction: the rows whose key is free are stored, a taken key answers its job."""
        for record, future in batch:
            try:
                try:
                    with self.writing(), self.engine.begin() as connection:
                        connection.exec_driver_sql(self.sql, [self._row(record)])
                    outcome = (self.made(record), True)
                except IntegrityError:
                    key = record.get("idempotency_key")
                    existing = self.find_by_key(key) if key is not None else None
                    if existing is None:
                        raise
                    outcome = (existing, False)
            except BaseException as error:
                future.set_exception(error)
            else:
                future.set_result(outcome)

    def _row(self, record: dict[str, Any]) -> tuple:
        # a None stays SQL NULL (the JSON type's processor would store JSON null)
        return tuple(None if (value := record[name]) is None else (process(value) if process else value)
                     for name, process in zip(self.columns, self.processors))
