"""IFC duplicate-geometry removal: rigid congruence classes, verified flyweight sharing, valid output.

Vonthron, Koch, König: removing duplicated geometries in IFC models using rigid body transformation
estimation and the flyweight design pattern. Phases: grouping (entity, attributes, invariant
signature) → correspondence-free rigid matching verified both ways → sharing (IfcMappedItem, or a
shared IfcProductDefinitionShape in IFC4+) → schema-aware post-pass → proof on the written file.
"""

from plantsolve.schemas.dedup import DedupRequest, DedupResult
from plantsolve.solvers.base import SolverSpec
from plantsolve.solvers.dedup.artifacts import render_artifacts
from plantsolve.solvers.dedup.solve import solve
from plantsolve.solvers.dedup.source import IfcSource, load
from plantsolve.solvers.dedup.synthetic import example
from plantsolve.solvers.dedup.upload import UPLOAD_EXTENSIONS, parse_upload
from plantsolve.solvers.dedup.validation import check_input

__version__ = "1.0.0"

SPEC = SolverSpec(
    kind="dedup",
    request_model=DedupRequest,
    result_model=DedupResult,
    solve=solve,
    version=__version__,
    load=load,
    check_input=check_input,
    parse_upload=parse_upload,
    render_artifacts=render_artifacts,
    upload_extensions=UPLOAD_EXTENSIONS,
    example=example,
    # the 4,240-segment tunnel (142 MB) takes about 20 CPU seconds; real exports can take much longer
    soft_time_limit=1200,
    time_limit=1320,
    description=__doc__.split("\n\n")[0],
)

__all__ = ["SPEC", "IfcSource", "load", "solve", "check_input", "parse_upload", "render_artifacts", "__version__"]
