"""A field file uploaded as a flowmeter job's file: the 415 says where it goes (options.magnetic_field_file), where it
said only "accepted: .json"; a kind without such a hint (SolverSpec.upload_hints) says what it did."""

import pytest

from plantsolve.jobs.errors import UnsupportedMediaType
from plantsolve.jobs.intake import upload_extension
from plantsolve.solvers.base import SolverSpec
from plantsolve.solvers.flowmeter import SPEC


def _refusal(spec: SolverSpec, name: str) -> str:
    with pytest.raises(UnsupportedMediaType) as refused:
        upload_extension(spec, name)
    assert refused.value.status == 415
    return refused.value.detail


def test_a_field_file_uploaded_as_the_file_is_a_415_naming_the_option():
    for name, extension in (("magnet_comsol.txt", ".txt"), ("field.csv", ".csv")):
        assert _refusal(SPEC, name) == (
            f"File type '{extension}' is not accepted by 'flowmeter'; accepted: .json. A magnetic field file (an FE "
            "tool's export: COMSOL .txt or .csv, a CSV with a header) is not uploaded as the file: put its text in the "
            "JSON request as options.magnetic_field_file.")
    plain = SolverSpec(kind="plain", request_model=SPEC.request_model, result_model=SPEC.result_model,
                       solve=SPEC.solve, version="1", parse_upload=SPEC.parse_upload, upload_extensions=(".json",))
    assert _refusal(plain, "field.csv") == "File type '.csv' is not accepted by 'plain'; accepted: .json."


def test_a_file_of_another_kind_is_not_told_about_field_files():
    assert _refusal(SPEC, "model.ifc") == "File type '.ifc' is not accepted by 'flowmeter'; accepted: .json."
