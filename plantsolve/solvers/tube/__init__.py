"""Bent-tube reconstruction from laser scans.

Paper: "parametric reconstruction of bent tube surfaces" (MLS spine, G1 arc-line splines,
LRA). Stages: local polynomial fits (``local_fit``), MLS spine (``spine``), polygonal curve
(``curve``), arc-line spline (``arcline``), least-squares LRA fit (``fit``), inspection
against a nominal LRA (``inspection``); ``solve.solve`` runs them in order on a ``TubeScan``
(the request with its samples decoded once).
"""

from __future__ import annotations

from plantsolve.schemas.tube import TubeRequest, TubeResult
from plantsolve.solvers.base import SolverSpec
from plantsolve.solvers.tube.artifacts import render_artifacts
from plantsolve.solvers.tube.scan import TubeScan
from plantsolve.solvers.tube.solve import solve
from plantsolve.solvers.tube.synthetic import example
from plantsolve.solvers.tube.upload import UPLOAD_EXTENSIONS, parse_upload
from plantsolve.solvers.tube.validation import check_input

__version__ = "1.0.0"

SPEC = SolverSpec(
    kind="tube",
    request_model=TubeRequest,
    result_model=TubeResult,
    solve=solve,
    version=__version__,
    load=TubeScan.load,
    check_input=check_input,
    parse_upload=parse_upload,
    render_artifacts=render_artifacts,
    upload_extensions=UPLOAD_EXTENSIONS,
    example=example,
    soft_time_limit=300,
    time_limit=900,
    description=__doc__.split("\n\n")[0],
)

__all__ = ["SPEC", "TubeScan", "solve", "check_input", "parse_upload", "render_artifacts", "__version__"]
