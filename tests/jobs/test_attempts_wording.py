"""How a job that failed on input and output is said: the machine's fault only where it surely is (a full disk, a
network away), never for a file that is no gzip (an OSError too, which the retry policy treats alike)."""

from __future__ import annotations

import errno
import gzip
import uuid

import pytest

from plantsolve.jobs.attempts import judge


@pytest.mark.parametrize("error, machines", [
    (OSError(errno.ENOSPC, "No space left on device"), True),
    (ConnectionError("connection refused"), True),
    (gzip.BadGzipFile("Not a gzipped file (b'ab')"), False),
    (FileNotFoundError(errno.ENOENT, "No such file or directory"), False),
])
def test_an_input_output_failure_blames_the_machine_only_where_it_surely_is(error, machines):
    verdict = judge(error, job_id=uuid.uuid4(), attempt=2, max_attempts=2, limits=(1.0, 2.0), elapsed=1.0)
    assert verdict.outcome == "failed" and verdict.report["stage"] == "infrastructure"
    assert ("not on the input" in verdict.report["message"]) == machines
    assert str(error) in verdict.report["message"]
