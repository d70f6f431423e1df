"""A test kind (through PLUGINS) whose report holds the warnings its request names: what the command line says and
exits with for a result that succeeded with a verdict against it, without a real solver's seconds."""

from __future__ import annotations

from pydantic import BaseModel, Field

from plantsolve.schemas.common import Diagnostic, Report, StrictModel
from plantsolve.solvers.base import Artifact, Solved, SolverSpec


class VerdictRequest(StrictModel):
    codes: list[str] = Field(default_factory=list, description="Codes of the warnings the report holds, in order.")


class VerdictResult(BaseModel):
    report: Report


def solve_verdict(request: VerdictRequest, progress) -> Solved:
    warnings = [Diagnostic(code=code, message=f"the {code} sentence") for code in request.codes]
    return Solved(VerdictResult(report=Report(status="warning" if warnings else "ok", message="judged",
                                              warnings=warnings)))


def render_verdict(request: VerdictRequest, solved: Solved) -> list[Artifact]:
    return [Artifact("codes.txt", "text/plain", "\n".join(request.codes).encode())]


SPECS = (SolverSpec("test-verdict", VerdictRequest, VerdictResult, solve_verdict, "test-1",
                    render_artifacts=render_verdict),)
