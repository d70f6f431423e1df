"""Bent-tube reconstruction from laser scans.

Paper: "parametric reconstruction of bent tube surfaces" (MLS spine, G1 arc-line splines,
LRA). Stages: local polynomial fits (``local_fit``), MLS spine (``spine``), polygonal curve
(``curve``), arc-line spline (``arcline``), least-squares LRA fit (``fit``), inspection
against a nominal LRA (``inspection``); ``solve.solve`` runs them in order on a ``TubeScan``
(the request with its samples decoded once).
"""

from __future__ import annotations

from plantsolve.schemas.tube import TubeRequest, TubeResult
from plantsolve.solvers.base import SolverSpec, stored_example

# the files upload.py reads, named here so that the kind map lists them without importing the reader (a test holds
# the two lists equal)
UPLOAD_EXTENSIONS = (".ply", ".stl", ".obj", ".e57", ".las", ".laz", ".xyz", ".csv", ".txt", ".npy", ".json")

__version__ = "1.0.0"

SPEC = SolverSpec(
    kind="tube",
    request_model=TubeRequest,
    result_model=TubeResult,
    solve="plantsolve.solvers.tube.solve:solve",
    version=__version__,
    load="plantsolve.solvers.tube.scan:TubeScan.load",
    check_input="plantsolve.solvers.tube.validation:check_input",
    parse_upload="plantsolve.solvers.tube.upload:parse_upload",
    render_artifacts="plantsolve.solvers.tube.artifacts:render_artifacts",
    upload_extensions=UPLOAD_EXTENSIONS,
    example=stored_example(__name__),  # synthetic.example(), written out
    soft_time_limit=300,
    time_limit=900,
    description=__doc__.split("\n\n")[0],
)

__all__ = ["SPEC", "UPLOAD_EXTENSIONS", "__version__"]
