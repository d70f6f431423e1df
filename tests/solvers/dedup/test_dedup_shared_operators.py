"""The mapped members' transformation operators made once per set of values (``sharing.SharedOperators``,
mapped_item with the post-pass) give the file that making one per member and letting the post-pass merge them
gives, byte for byte, with the same counts of what the post-pass removed; the numbers the post-pass gives the
kept operator matter: keeping the first one made instead gives another file."""

from __future__ import annotations

import ifcopenshell
import pytest

from plantsolve.solvers.dedup import compaction, postpass, sharing
from plantsolve.solvers.dedup.grouping import pool_transforms
from plantsolve.solvers.dedup.synthetic import build_model, tunnel_file, zoo_spec
from tests.solvers.dedup.support import classes_of
from tests.solvers.dedup.test_dedup_shared_placements import _reached_backwards


def _optimized(model: ifcopenshell.file, shared: sharing.SharedOperators | None, *, allow_mirror: bool = False,
               rebuild: bool = True) -> tuple[str, dict[str, int]]:
    """The model shared (mapped_item), compacted and merged by the post-pass: its STEP text and the post-pass's
    removed counts."""
    classes, reader = classes_of(model, allow_mirror=allow_mirror)
    pool_transforms(classes, 1e-5)  # as the solve does: a ring's members then get the same transform
    before = compaction.instance_ids(model)
    detached = sharing.Detached(model)
    sharing.apply(model, classes, "mapped_item", detached=detached, shared=shared)
    everything = compaction.grown(model, before, shared.skipped if shared else ())
    assert sorted(everything.tolist()) == sorted(model.entity_names())
    model = compaction.compacted(model, detached.roots, detached.styled_by, known=reader.closures,
                                 everything=everything, rebuild=rebuild)
    removed = postpass.merge_identical(model, shared=shared)
    return model.to_string().split("DATA;", 1)[1], removed  # the header holds the time of writing


MODELS = {"tunnel": lambda: tunnel_file(4, "IFC4", face_set="surface_model"),
          "tunnel reached backwards": lambda: _reached_backwards(tunnel_file(4, "IFC4", face_set="surface_model")),
          "tunnel IFC2X3": lambda: tunnel_file(3, "IFC2X3", face_set="surface_model"),
          "zoo": lambda: build_model(zoo_spec("IFC4"))}


@pytest.mark.parametrize("name", list(MODELS))
@pytest.mark.parametrize("allow_mirror", [False, True])
@pytest.mark.parametrize("rebuild", [True, False])
def test_made_once_gives_the_same_file_as_made_for_each_member(name, allow_mirror, rebuild):
    text, removed = _optimized(MODELS[name](), None, allow_mirror=allow_mirror, rebuild=rebuild)
    model = MODELS[name]()
    assert sharing.SharedOperators.applies(model)
    shared = sharing.SharedOperators(model)
    text_once, removed_once = _optimized(model, shared, allow_mirror=allow_mirror, rebuild=rebuild)
    assert text_once == text
    assert list(removed_once.items()) == list(removed.items())
    if name.startswith("tunnel"):  # a ring's operator serves its members of every class: most were not made
        assert len(shared.skipped) > len(sharing.OPERATOR_PARTS) * len(shared.groups)


def test_the_kept_operator_is_numbered_as_the_post_pass_keeps_it(monkeypatch):
    """The post-pass reaches a ring's mapped items in its own order, not in the order their operators were made:
    keeping each operator under the numbers it was made with gives another file."""
    text, _ = _optimized(MODELS["tunnel reached backwards"](), None)
    model = MODELS["tunnel reached backwards"]()
    monkeypatch.setattr(sharing.SharedOperators, "renumbered", lambda self, model, order, reached: order)
    text_first_made, _ = _optimized(model, sharing.SharedOperators(model))
    assert text_first_made != text
