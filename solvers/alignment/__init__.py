"""Pipe-system alignment (issue 3): make every connection of a scanned pipe model water-tight.

Paper: Klawitter, Tonn, Bringmann, *A dual quaternion based pipe alignment algorithm for
constrained pipe systems*. Two methods share model, validation, cuts and report:
``direct`` (rotation averaging + sparse KKT Gauss-Newton, the default) and
``dual_quaternion`` (the paper's alternating mean-displacement iteration).
"""

from solvers.alignment.artifacts import render_artifacts
from solvers.alignment.solve import solve
from solvers.alignment.upload import UPLOAD_EXTENSIONS, parse_upload
from solvers.alignment.validation import check_input

__version__ = "1.0.0"
TIME_LIMITS = (300, 900)

__all__ = ["solve", "check_input", "parse_upload", "render_artifacts", "UPLOAD_EXTENSIONS", "TIME_LIMITS", "__version__"]
