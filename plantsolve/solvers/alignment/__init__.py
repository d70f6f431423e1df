"""Pipe-system alignment: make every connection of a scanned pipe model water-tight.

Paper: Klawitter, Tonn, Bringmann, *A dual quaternion based pipe alignment algorithm for
constrained pipe systems*. Two methods share model, validation, cuts and report:
``direct`` (rotation averaging + sparse KKT Gauss-Newton, the default) and
``dual_quaternion`` (the paper's alternating mean-displacement iteration).
"""

from plantsolve.schemas.alignment import AlignmentRequest, AlignmentResult
from plantsolve.solvers.base import SolverSpec, stored_example

# the files upload.py reads, named here so that the kind map lists them without importing the reader (a test holds
# the two lists equal)
UPLOAD_EXTENSIONS = (".pcf", ".json")

__version__ = "1.0.0"

SPEC = SolverSpec(
    kind="alignment",
    request_model=AlignmentRequest,
    result_model=AlignmentResult,
    solve="plantsolve.solvers.alignment.solve:solve",
    version=__version__,
    check_input="plantsolve.solvers.alignment.validation:check_input",
    parse_upload="plantsolve.solvers.alignment.upload:parse_upload",
    render_artifacts="plantsolve.solvers.alignment.artifacts:render_artifacts",
    reader_notes="plantsolve.solvers.alignment.pcf:pcf_notes",
    upload_extensions=UPLOAD_EXTENSIONS,
    example=stored_example(__name__),  # synthetic.example(), written out
    soft_time_limit=300,
    time_limit=900,
    description=__doc__.split("\n\n")[0],
)

__all__ = ["SPEC", "UPLOAD_EXTENSIONS", "__version__"]
