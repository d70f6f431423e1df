"""Bend radius options that contradict each other are refused naming them. Before, one silently won: ``bend_radius``
over ``dies`` and ``bend_radius_model`` (a bend made on the 30 mm die of ``dies: [18, 30]`` was fitted at
``bend_radius: 18``), ``common_bend_radius`` over ``bend_radius_model``, ``dies`` over both."""

from pathlib import Path

import pytest
from pydantic import ValidationError

from plantsolve.schemas.tube import TubeOptions
from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.tube.upload import parse_upload

XYZ = (Path(__file__).parents[3] / "examples" / "tube" / "scan.xyz").read_bytes()


@pytest.mark.parametrize(("options", "named"), [
    ({"bend_radius": 18, "dies": [18, 30]}, ("bend_radius 18", "dies")),
    ({"bend_radius": 18, "bend_radius_model": "per_bend"}, ("bend_radius 18", "bend_radius_model 'per_bend'")),
    ({"bend_radius": 18, "bend_radius_model": "dies"}, ("bend_radius 18", "bend_radius_model 'dies'")),
    ({"common_bend_radius": True, "bend_radius_model": "per_bend"}, ("common_bend_radius", "'per_bend'")),
    ({"common_bend_radius": True, "dies": [18, 30]}, ("common_bend_radius", "dies")),
    ({"dies": [18, 30], "bend_radius_model": "common"}, ("dies", "bend_radius_model 'common'")),
])
def test_contradicting_bend_radius_options_are_refused_naming_them(options, named):
    with pytest.raises(ValidationError) as refused:
        TubeOptions.model_validate(options)
    (error,) = refused.value.errors()
    assert error["loc"] == () and error["type"] == "value_error"
    assert all(name in error["msg"] for name in named) and "contradict" in error["msg"]
    with pytest.raises(InputRejected) as upload:  # an upload's form says so too, as a 422 on options
        parse_upload(StoredInput.from_bytes("scan.xyz", XYZ), options)
    assert upload.value.errors[0].loc[:1] == ("options",) and "contradict" in upload.value.errors[0].msg


@pytest.mark.parametrize("options", [
    {"bend_radius": 18, "common_bend_radius": True}, {"bend_radius": 18, "bend_radius_model": "common"},
    {"common_bend_radius": True, "bend_radius_model": "common"}, {"dies": [18, 30], "bend_radius_model": "dies"},
    {"dies": [18, 30]}, {"bend_radius_model": "per_bend"}, {"bend_radius": 18, "bend_radius_model": "auto"},
])
def test_bend_radius_options_that_agree_are_taken(options):
    TubeOptions.model_validate(options)
