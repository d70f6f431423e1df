"""The job domain's tests share one service context: the embedded default (SQLite, a blob folder) under the test's
own temporary folder, migrated, closed after the test."""

from __future__ import annotations

import pytest

from plantsolve.jobs.context import ServiceContext
from tests.conftest import service_settings


@pytest.fixture
def ctx(tmp_path):
    context = ServiceContext.create(service_settings(tmp_path), migrate=True)
    yield context
    context.close()
