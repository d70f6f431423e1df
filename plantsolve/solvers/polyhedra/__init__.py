"""Polyhedral measures on generalized maps: zone volumes, areas with holes, closure diagnostics.

Soto-Francés, Sarabia-Escrivá, Pinazo-Ojer: consistently oriented dart-based 3-D modelling by means
of geometric algebra and combinatorial maps. Stages: repair (merge, T-junctions, hole orientation)
→ generalized map (darts, α0..α3) → measures per orbit (Newell, divergence theorem in each zone's
frame) → diagnostics (open/non-manifold edges, orientation, Euler characteristic, genus) → adjacency.
"""

from plantsolve.schemas.polyhedra import PolyhedraRequest, PolyhedraResult
from plantsolve.solvers.base import SolverSpec
from plantsolve.solvers.polyhedra.artifacts import render_artifacts
from plantsolve.solvers.polyhedra.solve import solve
from plantsolve.solvers.polyhedra.synthetic import example
from plantsolve.solvers.polyhedra.upload import UPLOAD_EXTENSIONS, parse_upload
from plantsolve.solvers.polyhedra.validation import check_input

__version__ = "1.0.0"

SPEC = SolverSpec(
    kind="polyhedra",
    request_model=PolyhedraRequest,
    result_model=PolyhedraResult,
    solve=solve,
    version=__version__,
    check_input=check_input,
    parse_upload=parse_upload,
    render_artifacts=render_artifacts,
    upload_extensions=UPLOAD_EXTENSIONS,
    example=example,
    # A 1,000-zone building solves in well under a second; a million-triangle STL in a few seconds
    # (bench/polyhedra.py).
    soft_time_limit=300,
    time_limit=600,
    description=__doc__.split("\n\n")[0],
)

__all__ = ["SPEC", "solve", "check_input", "parse_upload", "render_artifacts", "__version__"]
