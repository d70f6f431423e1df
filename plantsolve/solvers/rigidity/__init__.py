"""Jointed assemblies: superbricks, exact mobility and maximal rigid clusters, collisions, docking.

ESGI 51, LEGO chapter. Stages: superbricks by union-find over rigid connections (§3, §7.1) → the
body–joint graph with each joint's screw constraints → the generic (6,6) pebble game
(Tay–Whiteley; Jacobs–Hendrickson, Lee–Streinu) → the exact pass at the actual positions (screw
constraint matrix per biconnected block, exact modular rank for integer geometry, float SVD
otherwise) → rigid clusters from a basis of the motion space → collisions (axis-aligned broad phase
and FCL, §4) → docking at free connection points (§5).
"""

from plantsolve.schemas.rigidity import RigidityRequest, RigidityResult
from plantsolve.solvers.base import SolverSpec
from plantsolve.solvers.rigidity.artifacts import render_artifacts
from plantsolve.solvers.rigidity.solve import solve
from plantsolve.solvers.rigidity.synthetic import example
from plantsolve.solvers.rigidity.upload import UPLOAD_EXTENSIONS, parse_upload
from plantsolve.solvers.rigidity.validation import check_input

__version__ = "1.0.0"

SPEC = SolverSpec(
    kind="rigidity",
    request_model=RigidityRequest,
    result_model=RigidityResult,
    solve=solve,
    version=__version__,
    check_input=check_input,
    parse_upload=parse_upload,
    render_artifacts=render_artifacts,
    upload_extensions=UPLOAD_EXTENSIONS,
    example=example,
    # A 1,000-part model is analysed in well under a second; the limits are for huge uploads.
    soft_time_limit=300,
    time_limit=600,
    description=__doc__.split("\n\n")[0],
)

__all__ = ["SPEC", "solve", "check_input", "parse_upload", "render_artifacts", "__version__"]
