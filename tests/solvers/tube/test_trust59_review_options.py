"""Review of trust59a's bend radius rule: ``dies`` naming one radius is one radius for every bend, as ``common`` and
``bend_radius`` are (the solver holds every bend at that die); it was refused as contradicting them, so a request
that has run for a one-die bender (``dies: [18]`` with ``bend_radius_model: 'common'``) no longer ran. A
``bend_radius`` other than that die still contradicts it."""

import pytest
from pydantic import ValidationError

from plantsolve.schemas.tube import TubeOptions


@pytest.mark.parametrize("options", [
    {"dies": [18], "bend_radius_model": "common"}, {"dies": [18, 18.0], "common_bend_radius": True},
    {"dies": [18], "bend_radius": 18}, {"dies": [18], "bend_radius_model": "dies"},
])
def test_one_die_is_one_radius_for_every_bend(options):
    assert TubeOptions.model_validate(options).dies


@pytest.mark.parametrize(("options", "named"), [
    ({"dies": [18], "bend_radius": 20}, ("bend_radius 20", "dies [18]")),
    ({"dies": [18], "bend_radius_model": "per_bend"}, ("dies", "'per_bend'")),
])
def test_one_die_still_contradicts_another_radius_or_a_free_one(options, named):
    with pytest.raises(ValidationError) as refused:
        TubeOptions.model_validate(options)
    assert "contradict" in refused.value.errors()[0]["msg"]
    assert all(name in refused.value.errors()[0]["msg"] for name in named)
