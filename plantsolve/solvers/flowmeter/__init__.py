"""Electromagnetic flow meters: virtual current, weight function, sensitivity and linearity (ESGI 51, Siemens chapter).

The job computes the cross-section weight function of the electrodes (exactly for electrodes
along the whole liner and for point electrodes, by a Galerkin integral equation on the electrode
for patches of finite length and flush buttons, in a uniform or a gridded field, by finite
elements for protruding buttons and as the reference), the sensitivity S = U / (2 R B v_mean) for
the request's flow profile, W at probe points, S over Reynolds numbers and the electrode current
density.
"""

from plantsolve.schemas.flowmeter import FlowmeterRequest, FlowmeterResult
from plantsolve.solvers.base import SolverSpec
from plantsolve.solvers.flowmeter.artifacts import render_artifacts
from plantsolve.solvers.flowmeter.solve import solve
from plantsolve.solvers.flowmeter.synthetic import example
from plantsolve.solvers.flowmeter.upload import UPLOAD_EXTENSIONS, parse_upload
from plantsolve.solvers.flowmeter.validation import check_input

__version__ = "0.1.0"

SPEC = SolverSpec(
    kind="flowmeter",
    request_model=FlowmeterRequest,
    result_model=FlowmeterResult,
    solve=solve,
    version=__version__,
    check_input=check_input,
    parse_upload=parse_upload,
    render_artifacts=render_artifacts,
    upload_extensions=UPLOAD_EXTENSIONS,
    example=example,
    # closed forms take well under a second; the FEM reference a few seconds at its finest mesh
    soft_time_limit=120,
    time_limit=300,
    description=__doc__.split("\n\n")[0],
)

__all__ = ["SPEC", "solve", "check_input", "parse_upload", "render_artifacts", "__version__"]
