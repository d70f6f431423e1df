"""Group commit of submissions on SQLite (store/writer.py): every submission answered only after the commit that
holds its row, concurrent ones sharing a transaction, a taken idempotency key or a bad row failing alone, and the
rows the same as the per-submission insert writes."""

from __future__ import annotations

import threading
import uuid

import pytest
from sqlalchemy import event, text

from plantsolve.store.repository import JobRepository


def _columns(**fields) -> dict:
    return dict(id=uuid.uuid4(), kind="test-compute", body_hash="0" * 64, solver_version="1", **fields)


def _commits(engine) -> list[int]:
    commits: list[int] = []
    event.listen(engine, "commit", lambda connection: commits.append(1))
    return commits


def _stored_ids(ctx) -> set[uuid.UUID]:
    with ctx.db.engine.connect() as connection:
        return {uuid.UUID(hex=row[0]) for row in connection.execute(text("SELECT id FROM jobs"))}


def test_sqlite_stores_submissions_through_one_writer(ctx):
    assert ctx.repo.writer is not None


def test_submissions_waiting_together_share_one_commit_and_each_is_answered_after_it(ctx):
    commits = _commits(ctx.db.engine)
    with ctx.db.writing():  # another write holds the lock: the submissions queue behind it
        ctx.repo.create_later(_columns(input={"warm": 1}))  # the writer thread starts (and waits for the lock)
        futures = [ctx.repo.create_later(_columns(input={"i": i})) for i in range(20)]
        assert not any(future.done() for future in futures)  # nothing is answered before its commit
    answers = [future.result(timeout=30) for future in futures]
    assert all(created for _, created in answers)
    assert {job.id for job, _ in answers} <= _stored_ids(ctx)
    assert len(commits) <= 3, commits  # the first row alone, then the 20 in one or two transactions


def test_each_answer_follows_the_commit_of_its_row(ctx):
    seen_at_answer: list[bool] = []

    def check(future):
        job, _ = future.result()
        seen_at_answer.append(job.id in _stored_ids(ctx))  # another connection sees it: committed

    futures = [ctx.repo.create_later(_columns(input={"i": i})) for i in range(10)]
    for future in futures:
        future.add_done_callback(check)
    for future in futures:
        future.result(timeout=30)
    assert seen_at_answer == [True] * 10


def test_a_taken_key_in_a_batch_answers_its_job_and_the_others_are_stored(ctx):
    first, created = ctx.repo.create(_columns(idempotency_key="k-1", input={"a": 1}))
    assert created
    with ctx.db.writing():
        ctx.repo.create_later(_columns(input={"warm": 1}))
        futures = [ctx.repo.create_later(_columns(input={"b": 1})),
                   ctx.repo.create_later(_columns(idempotency_key="k-1", input={"a": 2})),
                   ctx.repo.create_later(_columns(input={"c": 1}))]
    (one, one_new), (again, again_new), (three, three_new) = (future.result(timeout=30) for future in futures)
    assert one_new and three_new and not again_new
    assert again.id == first.id and again.input == {"a": 1}
    assert {one.id, three.id, first.id} <= _stored_ids(ctx)


def test_the_same_key_twice_in_one_batch_is_one_job(ctx):
    with ctx.db.writing():
        ctx.repo.create_later(_columns(input={"warm": 1}))
        futures = [ctx.repo.create_later(_columns(idempotency_key="twice", input={"a": 1})) for _ in range(2)]
    answers = [future.result(timeout=30) for future in futures]
    assert sorted(created for _, created in answers) == [False, True]
    assert answers[0][0].id == answers[1][0].id


def test_a_row_the_database_refuses_fails_alone(ctx):
    with ctx.db.writing():
        ctx.repo.create_later(_columns(input={"warm": 1}))
        good = ctx.repo.create_later(_columns(input={"ok": 1}))
        bad = ctx.repo.create_later({**_columns(input={"bad": 1}), "kind": None})  # NOT NULL
    assert good.result(timeout=30)[1]
    with pytest.raises(Exception, match="NOT NULL"):
        bad.result(timeout=30)
    assert good.result()[0].id in _stored_ids(ctx)


def test_rows_are_the_same_as_the_per_submission_insert_writes(ctx):
    plain = JobRepository(ctx.db.sessions, ctx.db.writing)  # no group commit: one Core insert per submission
    fields = dict(input={"values": [1.5, 2.5], "name": "ä"}, idempotency_key="o:k", owner="o",
                  callback_url="https://example.com/hook", callback_state="pending", callback_attempts=0)
    grouped, _ = ctx.repo.create(_columns(**fields))
    single, _ = plain.create(_columns(**{**fields, "idempotency_key": "o:k2"}))
    columns = "status, attempt, max_attempts, progress, progress_message, input_kind, input, input_options, result, " \
              "report, owner, callback_url, callback_state, callback_attempts, typeof(created_at), " \
              "typeof(enqueued_at), length(created_at)"
    with ctx.db.engine.connect() as connection:
        rows = [connection.execute(text(f"SELECT {columns} FROM jobs WHERE id = :id"), {"id": job.id.hex}).one()
                for job in (grouped, single)]
    assert rows[0] == rows[1]
    a, b = ctx.repo.get(grouped.id), ctx.repo.get(single.id)
    assert (a.input, a.created_at.tzinfo, a.idempotency_key) == (b.input, b.created_at.tzinfo, "o:k")


def test_close_writes_what_is_queued_and_a_later_submission_starts_the_writer_again(ctx):
    with ctx.db.writing():
        ctx.repo.create_later(_columns(input={"warm": 1}))
        futures = [ctx.repo.create_later(_columns(input={"i": i})) for i in range(5)]
        closing = threading.Thread(target=ctx.repo.close)
        closing.start()
    closing.join(timeout=30)
    assert all(future.done() and future.result()[1] for future in futures)
    job, created = ctx.repo.create(_columns(input={"after": 1}))
    assert created and job.id in _stored_ids(ctx)


def test_a_lone_submission_is_written_at_once_on_the_calling_thread(ctx):
    commits = _commits(ctx.db.engine)  # the writer thread's transactions (the direct write uses no Connection)
    future = ctx.repo.create_later(_columns(input={"alone": 1}))
    assert future.done() and future.result()[1]
    assert future.result()[0].id in _stored_ids(ctx)
    assert ctx.repo.writer._thread is None and commits == []  # no hand-over to the writer thread


def test_a_write_held_by_another_process_is_never_waited_for_on_the_calling_thread(ctx, tmp_path):
    import sqlite3

    other = sqlite3.connect(ctx.db.engine.url.database, isolation_level=None)  # as a job process would
    other.execute("BEGIN IMMEDIATE")  # holds SQLite's write lock
    future = ctx.repo.create_later(_columns(input={"behind": 1}))
    # handed to the writer thread, which waits: a write on the calling thread would have ended, done or failed on
    # SQLite's busy timeout, before create_later returned (no clock: a busy machine does not move this)
    assert not future.done()
    other.execute("COMMIT")
    job, created = future.result(timeout=30)
    assert created and job.id in _stored_ids(ctx)
    other.close()
