"""A test kind whose check writes the id of the process that runs it (a plugin: PLUGINS=tests.jobs.pid_kind)."""

from __future__ import annotations

import os
from pathlib import Path

from pydantic import BaseModel, Field

from plantsolve.schemas.common import FiniteFloat, Report, StrictModel
from plantsolve.solvers.base import FieldError, InputRejected, Solved, SolverSpec


class PidRequest(StrictModel):
    values: list[FiniteFloat] = Field(min_length=1, max_length=200_000)
    count: int = Field(default=0, ge=0)
    pid_file: str


class PidResult(BaseModel):
    report: Report


def check_pid(request: PidRequest) -> None:
    Path(request.pid_file).write_text(str(os.getpid()))
    if request.values[0] < 0:
        raise InputRejected(FieldError(("values", 0), "must not be negative (test rule)"))


def solve_pid(request: PidRequest, progress) -> Solved:
    return Solved(PidResult(report=Report(message=f"{len(request.values)} values")))


SPECS = (SolverSpec("test-pid", PidRequest, PidResult, solve_pid, "test-1", check_input=check_pid),)
