"""A solver kind for the kill benches (``PLUGINS=tests.support.kinds,kill_kinds`` with this folder on the path):
``test-slow-render``, the tests' ``test-compute`` whose artifacts take ``render_seconds`` to render (a slow plot), so
that a kill between a solve and its result's commit can be aimed: the solve's marker file appears (named by the
solving process's pid), then the process renders for that long before it stores anything. Built from the checkout's
own ``tests.support.kinds``, so it runs on a ``--before`` checkout too."""

from __future__ import annotations

import time

from pydantic import Field

from plantsolve.solvers.base import SolverSpec
from tests.support.kinds import ComputeRequest, ComputeResult, render_compute, solve_compute


class SlowRenderRequest(ComputeRequest):
    render_seconds: float = Field(default=0.0, ge=0, le=60, description="Seconds the artifacts take to render.")


def render_slowly(request: SlowRenderRequest, solved):
    time.sleep(request.render_seconds)
    return render_compute(request, solved)


SPECS = (SolverSpec(kind="test-slow-render", request_model=SlowRenderRequest, result_model=ComputeResult,
                    solve=solve_compute, version="test-1", render_artifacts=render_slowly, soft_time_limit=60,
                    time_limit=90),)
