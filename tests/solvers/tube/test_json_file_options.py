"""An uploaded tube request's ``options`` must be an object: a list, a word or a number was merged with the form's
options by a ``TypeError`` that ended as a 422 with a logged traceback; now a refusal names ``file.options``."""

import json

import numpy as np
import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.tube.synthetic import make_model, surface_samples
from plantsolve.solvers.tube.upload import parse_upload

PTS = surface_samples(make_model([(400, 0, 90, 100), (300, 0, 0, 0)], 20.0), 300, np.random.default_rng(0))


@pytest.mark.parametrize("options", [[1, 2], "fast", 3])
def test_a_json_files_options_that_are_no_object_are_refused_naming_them(options):
    body = {"points": PTS.tolist(), "units": "mm", "options": options}
    with pytest.raises(InputRejected) as refused:
        parse_upload(StoredInput.from_bytes("scan.json", json.dumps(body).encode()), {"tolerance": 0.5})
    assert refused.value.errors[0].loc == ("file", "options") and "object" in refused.value.errors[0].msg


def test_a_json_files_options_object_is_merged_with_the_forms():
    body = {"points": PTS.tolist(), "units": "mm", "options": {"pipe_radius": 20.0}}
    request = parse_upload(StoredInput.from_bytes("scan.json", json.dumps(body).encode()), None)
    assert request.options.pipe_radius == 20.0
