"""A migrated service context on a temporary SQLite store, for the store's tests."""

import pytest

from plantsolve.jobs.context import ServiceContext
from tests.conftest import service_settings


@pytest.fixture
def ctx(tmp_path):
    context = ServiceContext.create(service_settings(tmp_path))
    context.db.migrate()
    yield context
    context.close()
