"""The mapped members' transformation operators made once per set of values (``sharing.SharedOperators``,
mapped_item with the post-pass) give the file that making one per member and letting the post-pass merge them
gives, byte for byte, with the same counts of what the post-pass removed; the numbers the post-pass gives the
kept operator matter: keeping the first one made instead gives another file."""

from __future__ import annotations

import pytest

from plantsolve.solvers.dedup import sharing
from plantsolve.solvers.dedup.synthetic import build_model, tunnel_file, zoo_spec
from tests.solvers.dedup.support import shared_and_merged
from tests.solvers.dedup.test_dedup_shared_placements import _reached_backwards


MODELS = {"tunnel": lambda: tunnel_file(4, "IFC4", face_set="surface_model"),
          "tunnel reached backwards": lambda: _reached_backwards(tunnel_file(4, "IFC4", face_set="surface_model")),
          "tunnel IFC2X3": lambda: tunnel_file(3, "IFC2X3", face_set="surface_model"),
          "zoo": lambda: build_model(zoo_spec("IFC4"))}


@pytest.mark.parametrize("name", list(MODELS))
@pytest.mark.parametrize("allow_mirror", [False, True])
@pytest.mark.parametrize("rebuild", [True, False])
def test_made_once_gives_the_same_file_as_made_for_each_member(name, allow_mirror, rebuild):
    text, removed = shared_and_merged(MODELS[name](), "mapped_item", None,
                                       allow_mirror=allow_mirror, rebuild=rebuild)
    model = MODELS[name]()
    assert sharing.SharedOperators.applies(model)
    shared = sharing.SharedOperators(model)
    text_once, removed_once = shared_and_merged(model, "mapped_item", shared,
                                       allow_mirror=allow_mirror, rebuild=rebuild)
    assert text_once == text
    assert list(removed_once.items()) == list(removed.items())
    if name.startswith("tunnel"):  # a ring's operator serves its members of every class: most were not made
        assert len(shared.skipped) > len(sharing.OPERATOR_PARTS) * len(shared.groups)


def test_the_kept_operator_is_numbered_as_the_post_pass_keeps_it(monkeypatch):
    """The post-pass reaches a ring's mapped items in its own order, not in the order their operators were made:
    keeping each operator under the numbers it was made with gives another file."""
    text, _ = shared_and_merged(MODELS["tunnel reached backwards"](), "mapped_item", None)
    model = MODELS["tunnel reached backwards"]()
    monkeypatch.setattr(sharing.SharedOperators, "renumbered", lambda self, model, order, reached: order)
    text_first_made, _ = shared_and_merged(model, "mapped_item", sharing.SharedOperators(model))
    assert text_first_made != text
