"""The repository's text search (the dashboard's free-text filter) on SQLite and PostgreSQL: a UUID
is stored as 32 hex digits by the one and printed with dashes by the other."""

from __future__ import annotations

import uuid

import pytest

from plantsolve.store import Database, JobRepository
def _job(kind: str, message: str, report: dict | None = None, owner: str = "") -> dict:
    return dict(id=uuid.uuid4(), kind=kind, status="succeeded", progress_message=message, report=report, owner=owner,
                body_hash="0" * 64, solver_version="1", input={"secret": "not searched"})


def _check_search(db: Database) -> None:
    db.migrate()
    repo = JobRepository(db.sessions, db.writing)
    fan = _job("perfmap", "done", {"status": "warning", "message": "map 40x40", "warnings": [
        {"code": "pressure_fit_poor", "message": "Setting theta=0: misses by 2.26%", "details": {}}]})
    house = _job("polyhedra", "done", {"status": "ok", "message": "1 of 1 zone(s) closed", "warnings": []})
    other = _job("polyhedra", "Zone_B closed", None, owner="bob")
    fan, house, other = (repo.create(job)[0] for job in (fan, house, other))

    mine = {fan.id, house.id, other.id}  # the PostgreSQL database is shared by the session's other tests

    def found(text: str, owner: str | None = None) -> set[uuid.UUID]:
        return {job.id for job in repo.list(text=text, owner=owner, brief=True, limit=1000)} & mine

    dashed = str(house.id)
    assert found(dashed) == {house.id}  # the whole id, with dashes
    assert found(dashed[9:23].upper()) == {house.id}  # a middle part across dashes, any case
    assert found(house.id.hex[:10]) == {house.id}
    assert found("POLY") == {house.id, other.id}
    assert found("pressure_fit") == {fan.id}  # a warning's code
    assert found("2.26%") == {fan.id}  # % is a character here, not LIKE's wildcard
    assert found("2_26") == set() and found("%") == {fan.id}
    assert found("zone_b") == {other.id} and found("zone_b", owner="") == set()  # _ is literal; owners apply
    assert found("not searched") == set()  # the input is not part of the search
    listed = repo.list(text="poly", brief=True, limit=1000)
    assert [job.id for job in listed if job.id in mine] == [other.id, house.id]  # newest first, as without text


def test_text_search_on_sqlite(tmp_path):
    db = Database(f"sqlite:///{tmp_path / 'search.db'}")
    try:
        _check_search(db)
    finally:
        db.dispose()


@pytest.mark.integration
def test_text_search_on_postgresql(pg_url):
    db = Database(pg_url)
    try:
        _check_search(db)
    finally:
        db.dispose()
