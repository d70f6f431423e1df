"""Compressor performance maps from rig measurements (ESGI 51, HV-Turbo chapter).

The job computes characteristics, envelopes, the maximum-efficiency map and the speed lines on a beta grid
(exported for cycle codes); the inverse query (``POST /v1/perfmap/jobs/{id}/query``) answers duty points from a
finished map, ``POST /v1/perfmap/jobs/{id}/beta`` answers (speed, beta) lookups.
"""

from plantsolve.schemas.perfmap import (
    PerfmapBetaQueryRequest,
    PerfmapBetaQueryResult,
    PerfmapQueryRequest,
    PerfmapQueryResult,
    PerfmapRequest,
    PerfmapResult,
)
from plantsolve.solvers.base import ResultOperation, SolverSpec, stored_example

# the files upload.py reads, named here so that the kind map lists them without importing the reader (a test holds
# the two lists equal)
UPLOAD_EXTENSIONS = (".csv", ".xlsx", ".json", ".py", ".map")

__version__ = "1.2.0"

SPEC = SolverSpec(
    kind="perfmap",
    request_model=PerfmapRequest,
    result_model=PerfmapResult,
    solve="plantsolve.solvers.perfmap.solve:solve",
    version=__version__,
    load="plantsolve.solvers.perfmap.validation:load",
    check_input="plantsolve.solvers.perfmap.validation:check_input",
    parse_upload="plantsolve.solvers.perfmap.upload:parse_upload",
    render_artifacts="plantsolve.solvers.perfmap.artifacts:render_artifacts",
    upload_extensions=UPLOAD_EXTENSIONS,
    example=stored_example(__name__),  # synthetic.example(), written out
    # Typical runs take about a second (28 settings, 64x64 map); minimax with the log family
    # and 1000x1000 maps take tens of seconds.
    soft_time_limit=120,
    time_limit=300,
    description=__doc__.split("\n\n")[0],
    operations=(
        ResultOperation(
            name="query",
            request_model=PerfmapQueryRequest,
            response_model=PerfmapQueryResult,
            answer="plantsolve.solvers.perfmap.query:answer_query",
            summary="Inverse query: optimal settings and efficiency for duty points",
            description="One `{flow, pressure}` or `{points: [...]}`. Points outside the reachable region "
            "come back with `feasible: false` and their distance to the map instead of an extrapolation.",
            example=lambda: {"points": [{"flow": 2000.0, "pressure": 1.15}, {"flow": 1000.0, "pressure": 1.6}]},
        ),
        ResultOperation(
            name="beta",
            request_model=PerfmapBetaQueryRequest,
            response_model=PerfmapBetaQueryResult,
            answer="plantsolve.solvers.perfmap.query:answer_beta_query",
            summary="Map lookup by (speed, beta): corrected flow, pressure ratio and efficiency",
            description="One `{speed, beta}` (or `{setting: [...], beta}` with several setting parameters) or "
            "`{points: [...]}`. Beta 0 is the choke line, 1 the surge line. Exact on a fitted speed line, linear in "
            "speed between neighbouring lines; speeds outside the lines are refused (422), not extrapolated.",
            example=lambda: {"points": [{"setting": [0.0, 0.9], "beta": 0.5}, {"setting": [0.0, 1.0], "beta": 1.0}]},
        ),
    ),
)

__all__ = ["SPEC", "UPLOAD_EXTENSIONS", "__version__"]
