"""Jointed assemblies: superbricks, exact mobility and maximal rigid clusters, collisions, docking.

ESGI 51, LEGO chapter. Stages: superbricks by union-find over rigid connections (§3, §7.1) → the
body–joint graph with each joint's screw constraints → the generic (6,6) pebble game
(Tay–Whiteley; Jacobs–Hendrickson, Lee–Streinu) → the exact pass at the actual positions (screw
constraint matrix per biconnected block, exact modular rank for integer geometry, float SVD
otherwise) → rigid clusters from a basis of the motion space → collisions (axis-aligned broad phase
and FCL, §4) → docking at free connection points (§5).
"""

from plantsolve.schemas.rigidity import RigidityRequest, RigidityResult
from plantsolve.solvers.base import SolverSpec, stored_example

# the files upload.py reads, named here so that the kind map lists them without importing the reader (a test holds
# the two lists equal)
UPLOAD_EXTENSIONS = (".ldr", ".mpd", ".json")

__version__ = "1.0.0"

SPEC = SolverSpec(
    kind="rigidity",
    request_model=RigidityRequest,
    result_model=RigidityResult,
    solve="plantsolve.solvers.rigidity.solve:solve",
    version=__version__,
    check_input="plantsolve.solvers.rigidity.validation:check_input",
    parse_upload="plantsolve.solvers.rigidity.upload:parse_upload",
    render_artifacts="plantsolve.solvers.rigidity.artifacts:render_artifacts",
    upload_extensions=UPLOAD_EXTENSIONS,
    example=stored_example(__name__),  # synthetic.example(), written out
    # A 1,000-part model is analysed in well under a second; the limits are for huge uploads.
    soft_time_limit=300,
    time_limit=600,
    description=__doc__.split("\n\n")[0],
)

__all__ = ["SPEC", "UPLOAD_EXTENSIONS", "__version__"]
