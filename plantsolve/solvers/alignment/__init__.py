"""Pipe-system alignment: make every connection of a scanned pipe model water-tight.

Paper: Klawitter, Tonn, Bringmann, *A dual quaternion based pipe alignment algorithm for
constrained pipe systems*. Two methods share model, validation, cuts and report:
``direct`` (rotation averaging + sparse KKT Gauss-Newton, the default) and
``dual_quaternion`` (the paper's alternating mean-displacement iteration).
"""

from plantsolve.schemas.alignment import AlignmentRequest, AlignmentResult
from plantsolve.solvers.alignment.artifacts import render_artifacts
from plantsolve.solvers.alignment.solve import solve
from plantsolve.solvers.alignment.synthetic import example
from plantsolve.solvers.alignment.upload import UPLOAD_EXTENSIONS, parse_upload
from plantsolve.solvers.alignment.validation import check_input
from plantsolve.solvers.base import SolverSpec

__version__ = "1.0.0"

SPEC = SolverSpec(
    kind="alignment",
    request_model=AlignmentRequest,
    result_model=AlignmentResult,
    solve=solve,
    version=__version__,
    check_input=check_input,
    parse_upload=parse_upload,
    render_artifacts=render_artifacts,
    upload_extensions=UPLOAD_EXTENSIONS,
    example=example,
    soft_time_limit=300,
    time_limit=900,
    description=__doc__.split("\n\n")[0],
)

__all__ = ["SPEC", "solve", "check_input", "parse_upload", "render_artifacts", "__version__"]
