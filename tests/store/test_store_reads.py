"""The store's submit insert and status reads: what they write and what they load."""

from __future__ import annotations

import uuid

import pytest
from sqlalchemy import text

from plantsolve.store.repository import JobRecord


def _job(**fields) -> dict:
    return dict(id=uuid.uuid4(), kind="test-compute", body_hash="0" * 64, solver_version="1", **fields)


def test_insert_applies_defaults_and_leaves_unset_json_columns_sql_null(ctx):
    job, created = ctx.repo.create(_job(input={"values": [1.0]}))
    assert created and job.status == "queued" and job.attempt == 0 and job.created_at is not None
    with ctx.db.engine.connect() as connection:
        row = connection.execute(
            text("SELECT status, progress, result IS NULL, report IS NULL, attempts IS NULL, input FROM jobs WHERE id = :id"),
            {"id": job.id.hex},
        ).one()
    assert row[:5] == ("queued", 0.0, 1, 1, 1)
    assert ctx.repo.get(job.id).input == {"values": [1.0]}


def test_same_idempotency_key_returns_the_stored_job(ctx):
    first, created = ctx.repo.create(_job(idempotency_key="k-1", input={"a": 1}))
    again, created_again = ctx.repo.create(_job(idempotency_key="k-1", input={"a": 2}))
    assert created and not created_again and again.id == first.id and again.input == {"a": 1}


def test_a_brief_read_never_loads_the_input_or_the_result(ctx):
    job, _ = ctx.repo.create(_job(input={"values": list(range(1000))}))
    brief = ctx.repo.get(job.id, brief=True)
    assert brief.status == "queued" and brief.kind == "test-compute"
    for name in ("input", "result", "input_options"):  # not selected: a row without them
        with pytest.raises(AttributeError):
            getattr(brief, name)
    assert ctx.repo.get(job.id).input["values"][-1] == 999


def test_every_read_gives_the_one_frozen_job_record(ctx):
    job, _ = ctx.repo.create(_job(idempotency_key="k-2", input={"a": 1}))
    reads = [job, ctx.repo.get(job.id), ctx.repo.get(job.id, brief=True), ctx.repo.get_by_idempotency_key("k-2"),
             *ctx.repo.list(), *ctx.repo.list(brief=True), ctx.repo.create(_job(idempotency_key="k-2"))[0]]
    assert {type(read) for read in reads} == {JobRecord} and {read.id for read in reads} == {job.id}
    with pytest.raises(AttributeError):  # frozen: a change is a write, and a write a new read
        reads[1].status = "failed"
