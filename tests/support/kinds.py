"""Test-only solver kinds that exercise the job machinery (added through the PLUGINS setting).

None of them ships with the service: they exist to make the runner sleep, crash, hang,
reject input, and compute something deterministic, so the lifecycle can be tested without
depending on a real solver's speed.
"""

from __future__ import annotations

import os
import time
from pathlib import Path

import numpy as np
from pydantic import BaseModel, Field

from plantsolve.schemas.common import FiniteFloat, Report, StrictModel
from plantsolve.solvers.base import Artifact, FieldError, InputRejected, Solved, SolverError, SolverSpec, StoredInput


class ComputeRequest(StrictModel):
    values: list[FiniteFloat] = Field(min_length=1, max_length=100_000)
    seconds: float = Field(default=0.0, ge=0, le=600, description="Sleep this long in 20 steps (progress reported).")
    marker_dir: str | None = Field(default=None, description="Write one file per completed run here (counts runs).")


class ComputeResult(BaseModel):
    total: float
    norm: float
    spectrum: list[float]
    report: Report


def solve_compute(request: ComputeRequest, progress) -> Solved:
    steps = 20
    for step in range(steps):
        progress(step / steps, f"step {step + 1} of {steps}")
        if request.seconds:
            time.sleep(request.seconds / steps)
    values = np.asarray(request.values, dtype=float)
    rng = np.random.default_rng(len(values))
    matrix = rng.standard_normal((8, 8))
    spectrum = np.linalg.eigvalsh(matrix + matrix.T).tolist()
    if request.marker_dir:
        folder = Path(request.marker_dir)
        folder.mkdir(parents=True, exist_ok=True)
        (folder / f"done-{os.getpid()}-{time.monotonic_ns()}").write_text("1")
    warnings = [] if values.min() >= 0 else [{"code": "negative", "message": "Some values are negative."}]
    with np.errstate(over="ignore"):  # overflow to inf is what one test wants
        total, norm = float(values.sum()), float(np.linalg.norm(values))
    return Solved(ComputeResult(
        total=total,
        norm=norm,
        spectrum=spectrum,
        report=Report(status="warning" if warnings else "ok", message="computed", warnings=warnings),
    ))


def check_compute(request: ComputeRequest) -> None:
    bad = [FieldError(("values", i), "must not be 666 (test rule)") for i, v in enumerate(request.values) if v == 666]
    if bad:
        raise InputRejected(bad)


def parse_compute(source: StoredInput, options: dict | None) -> ComputeRequest:
    options = dict(options or {})
    # a reader that computes (or waits) this long first: the bounded read's CPU budget against its wall clock
    spin_until = time.process_time() + float(options.pop("read_cpu_seconds", 0))
    while time.process_time() < spin_until:
        pass
    time.sleep(float(options.pop("read_wait_seconds", 0)))
    try:
        values = [float(line) for line in source.read().decode().split() if line.strip()]
    except (UnicodeDecodeError, ValueError) as error:
        raise InputRejected(FieldError(("file",), f"not a list of numbers: {error}")) from None
    return ComputeRequest.model_validate({"values": values, **options})


def render_compute(request: ComputeRequest, solved: Solved) -> list[Artifact]:
    text = "\n".join(f"{v!r}" for v in request.values).encode()
    return [Artifact("values.txt", "text/plain", text),
            Artifact("summary.json", "application/json", solved.result.model_dump_json().encode())]


class CrashRequest(StrictModel):
    message: str = "boom"
    error: str = Field(default="ConnectionError", description="ConnectionError (infrastructure: retried), "
                       "LinAlgError or ValueError (input-dependent: failed at once), MemoryError.")


class CrashResult(BaseModel):
    report: Report


ERRORS = {"ConnectionError": ConnectionError, "LinAlgError": np.linalg.LinAlgError, "ValueError": ValueError,
          "MemoryError": MemoryError, "OSError": OSError}


def solve_crash(request: CrashRequest, progress) -> CrashResult:
    progress(0.1, "about to crash")
    raise ERRORS[request.error](request.message)


def solve_fail(request: CrashRequest, progress) -> CrashResult:
    raise SolverError("fit", request.message, {"residual": 1.5})


def solve_hang(request: CrashRequest, progress) -> CrashResult:
    while True:  # never reports progress: only the time limit can stop it
        time.sleep(0.05)


def solve_stubborn(request: CrashRequest, progress) -> CrashResult:
    while True:  # swallows even Celery's SoftTimeLimitExceeded: only a kill stops it
        try:
            time.sleep(0.05)
        except BaseException:
            pass


SPECS = (
    SolverSpec(
        kind="test-compute",
        request_model=ComputeRequest,
        result_model=ComputeResult,
        solve=solve_compute,
        version="test-1",
        check_input=check_compute,
        parse_upload=parse_compute,
        render_artifacts=render_compute,
        upload_extensions=(".txt",),
        soft_time_limit=60,
        time_limit=90,
    ),
    SolverSpec("test-crash", CrashRequest, CrashResult, solve_crash, "test-1", max_attempts=2),
    SolverSpec("test-fail", CrashRequest, CrashResult, solve_fail, "test-1"),
    SolverSpec("test-hang", CrashRequest, CrashResult, solve_hang, "test-1", soft_time_limit=1.0, time_limit=2.0),
    SolverSpec("test-stubborn", CrashRequest, CrashResult, solve_stubborn, "test-1", soft_time_limit=1.0, time_limit=2.0),
)
