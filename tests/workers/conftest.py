"""Process-wide state of the job processes' and readers' forkserver, fresh for each test here."""

from __future__ import annotations

import pytest

from plantsolve.jobs import intake
from plantsolve.jobs.context import ServiceContext
from tests.conftest import service_settings


@pytest.fixture(autouse=True)
def fresh_forkserver_starts(monkeypatch):
    """:data:`plantsolve.jobs.intake.FORKSERVER_STARTS` as at a process's start, and as before once the test ended:
    the failures and the pause a test leaves (one of a forkserver that dies at every start) would otherwise pause the
    forkserver's starts of the tests after it, depending on their order."""
    gate = intake.FORKSERVER_STARTS
    for name, value in vars(intake.ForkserverStarts()).items():
        if name != "_lock":
            monkeypatch.setattr(gate, name, value)
    return gate


@pytest.fixture
def ctx(tmp_path):
    """A migrated service context of the embedded job processes (a module may define its own)."""
    context = ServiceContext.create(service_settings(tmp_path, embedded_mode="process"), migrate=True)
    yield context
    context.close()
