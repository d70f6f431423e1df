"""Polyhedral measures on generalized maps: zone volumes, areas with holes, closure diagnostics.

Soto-Francés, Sarabia-Escrivá, Pinazo-Ojer: consistently oriented dart-based 3-D modelling by means
of geometric algebra and combinatorial maps. Stages: repair (merge, T-junctions, hole orientation)
→ generalized map (darts, α0..α3) → measures per orbit (Newell, divergence theorem in each zone's
frame) → diagnostics (open/non-manifold edges, orientation, Euler characteristic, genus) → adjacency.
"""

from plantsolve.schemas.polyhedra import PolyhedraRequest, PolyhedraResult
from plantsolve.solvers.base import SolverSpec, stored_example

# the files upload.py reads, named here so that the kind map lists them without importing the reader (a test holds
# the two lists equal)
UPLOAD_EXTENSIONS = (".idf", ".epjson", ".xml", ".gbxml", ".ifc", ".obj", ".stl", ".json")

__version__ = "1.0.0"

SPEC = SolverSpec(
    kind="polyhedra",
    request_model=PolyhedraRequest,
    result_model=PolyhedraResult,
    solve="plantsolve.solvers.polyhedra.solve:solve",
    version=__version__,
    check_input="plantsolve.solvers.polyhedra.validation:check_input",
    parse_upload="plantsolve.solvers.polyhedra.upload:parse_upload",
    render_artifacts="plantsolve.solvers.polyhedra.artifacts:render_artifacts",
    upload_extensions=UPLOAD_EXTENSIONS,
    example=stored_example(__name__),  # synthetic.example(), written out
    # A 1,000-zone building solves in well under a second; a million-triangle STL in a few seconds
    # (bench/polyhedra.py).
    soft_time_limit=300,
    time_limit=600,
    description=__doc__.split("\n\n")[0],
)

__all__ = ["SPEC", "UPLOAD_EXTENSIONS", "__version__"]
