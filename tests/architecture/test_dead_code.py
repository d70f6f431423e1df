"""No dead code in the job runtime's rooms (jobs/, store/, workers/, the app factory, the CLI), by vulture.

What vulture cannot see being used is named below with the reason it stays: functions that a framework calls
(routes, signal handlers, validators, a module's ``__getattr__``), a transport class Celery loads by name, and the
dispatcher's test-facing counters."""

from __future__ import annotations

from pathlib import Path

import pytest

vulture = pytest.importorskip("vulture")

REPO = Path(__file__).resolve().parents[2]
ROOMS = ["plantsolve/jobs", "plantsolve/store", "plantsolve/workers", "plantsolve/app/main.py", "plantsolve/cli.py"]
# Alembic reads a revision's module-level names and calls upgrade/downgrade by name
EXCLUDE = ["plantsolve/store/migrations"]
# decorated functions a framework calls: FastAPI routes, Celery signal handlers, pydantic validators, SQLAlchemy
# event listeners
DECORATORS = ["@app.get", "@signals.*", "@field_validator", "@contextmanager", "@event.listens_for"]
STAY = {
    "__getattr__": "plantsolve.store's lazy re-exports (PEP 562: Python calls it)",
    "openapi": "FastAPI reads app.openapi",
    "PublishingTransport": "loaded by Celery from broker_transport='plantsolve.workers.celery_app:PublishingTransport'",
    "conn_or_acquire": "kombu's channel calls it (overridden to publish through one client)",
    "broker_transport": "a Celery setting, read by Celery",
    "in_flight": "the dispatcher's count of jobs in hand, read by the tests of the backlog window",
}


def test_vulture_finds_no_dead_code_in_the_runtime():
    finder = vulture.Vulture(ignore_names=list(STAY), ignore_decorators=DECORATORS)
    # the whole package is read (a room's code may be used from another), the rooms' findings reported
    finder.scavenge([str(REPO / "plantsolve")], exclude=[str(REPO / path) for path in EXCLUDE])
    found = [(str(Path(item.filename).resolve().relative_to(REPO)), item) for item in
             finder.get_unused_code(min_confidence=60)]
    dead = [f"{name}:{item.first_lineno} {item.typ} {item.name}" for name, item in found
            if any(name == room or name.startswith(room + "/") for room in ROOMS)]
    assert dead == []
