"""Electromagnetic flow meters: virtual current, weight function, sensitivity and linearity (ESGI 51, Siemens chapter).

The job computes the cross-section weight function of the electrodes (exactly for electrodes
along the whole liner and for point electrodes, by a Galerkin integral equation on the electrode
for patches of finite length and flush buttons, in a uniform or a gridded field, by finite
elements for protruding buttons and as the reference), the sensitivity S = U / (2 R B v_mean) for
the request's flow profile, W at probe points, S over Reynolds numbers and the electrode current
density.
"""

from plantsolve.schemas.flowmeter import FlowmeterRequest, FlowmeterResult
from plantsolve.solvers.base import SolverSpec, stored_example

# the files upload.py reads, named here so that the kind map lists them without importing the reader (a test holds
# the two lists equal)
UPLOAD_EXTENSIONS = (".json",)

__version__ = "0.1.0"

SPEC = SolverSpec(
    kind="flowmeter",
    request_model=FlowmeterRequest,
    result_model=FlowmeterResult,
    solve="plantsolve.solvers.flowmeter.solve:solve",
    version=__version__,
    check_input="plantsolve.solvers.flowmeter.validation:check_input",
    parse_upload="plantsolve.solvers.flowmeter.upload:parse_upload",
    render_artifacts="plantsolve.solvers.flowmeter.artifacts:render_artifacts",
    upload_extensions=UPLOAD_EXTENSIONS,
    # the one file a flowmeter job reads besides its request is a field file, which the request holds as text
    upload_hints=(((".txt", ".csv", ".tsv", ".dat"), "A magnetic field file (an FE tool's export: COMSOL .txt or .csv, a CSV "
                   "with a header) is not uploaded as the file: put its text in the JSON request as "
                   "options.magnetic_field_file."),),
    example=stored_example(__name__),  # synthetic.example(), written out
    # closed forms take well under a second; the FEM reference a few seconds at its finest mesh
    soft_time_limit=120,
    time_limit=300,
    description=__doc__.split("\n\n")[0],
)

__all__ = ["SPEC", "UPLOAD_EXTENSIONS", "__version__"]
