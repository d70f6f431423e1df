"""IFC duplicate-geometry removal: rigid congruence classes, verified flyweight sharing, valid output.

Vonthron, Koch, König: removing duplicated geometries in IFC models using rigid body transformation
estimation and the flyweight design pattern. Phases: grouping (entity, attributes, invariant
signature) → correspondence-free rigid matching verified both ways → sharing (IfcMappedItem, or a
shared IfcProductDefinitionShape in IFC4+) → schema-aware post-pass → proof on the written file.
"""

from plantsolve.schemas.dedup import DedupRequest, DedupResult
from plantsolve.solvers.base import SolverSpec, stored_example

# the files upload.py reads, named here so that the kind map lists them without importing the reader (a test holds
# the two lists equal)
UPLOAD_EXTENSIONS = (".ifc", ".ifczip", ".json")

__version__ = "1.0.0"

SPEC = SolverSpec(
    kind="dedup",
    request_model=DedupRequest,
    result_model=DedupResult,
    solve="plantsolve.solvers.dedup.solve:solve",
    version=__version__,
    load="plantsolve.solvers.dedup.source:load",
    check_input="plantsolve.solvers.dedup.validation:check_input",
    parse_upload="plantsolve.solvers.dedup.upload:parse_upload",
    render_artifacts="plantsolve.solvers.dedup.artifacts:render_artifacts",
    upload_extensions=UPLOAD_EXTENSIONS,
    example=stored_example(__name__),  # synthetic.example(), written out
    # the 4,240-segment tunnel (142 MB) takes about 20 CPU seconds; real exports can take much longer
    soft_time_limit=1200,
    time_limit=1320,
    description=__doc__.split("\n\n")[0],
)

__all__ = ["SPEC", "UPLOAD_EXTENSIONS", "__version__"]
