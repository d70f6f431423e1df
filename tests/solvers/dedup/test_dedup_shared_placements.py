"""The members' new placements made once per set of values (``sharing.SharedPlacements``, product_shape
with the post-pass) give the file that making one per member and letting the post-pass merge them gives,
byte for byte, with the same counts of what the post-pass removed; and the numbers the post-pass gives the
kept placement matter: keeping the first one made instead gives another file."""

from __future__ import annotations

import pytest

import ifcopenshell

from plantsolve.solvers.dedup import sharing
from plantsolve.solvers.dedup.synthetic import build_model, tunnel_file, zoo_spec
from tests.solvers.dedup.support import shared_and_merged


def _reached_backwards(model: ifcopenshell.file) -> ifcopenshell.file:
    """``model`` renumbered one up, with a group as #1 whose assignment (#2) lists every product: the
    post-pass, taking its roots in number order, then reaches the products from the last listed on (its
    stack), each ring's members in the opposite order to that their placements are made in."""
    import re

    body = model.to_string().split("DATA;\n", 1)[1].split("ENDSEC;", 1)[0]
    body = re.sub(r"#(\d+)", lambda m: f"#{int(m.group(1)) + 2}", body)
    products = ",".join(f"#{p.id() + 2}" for p in sorted(model.by_type("IfcProduct"), key=lambda p: p.id())
                        if p.Representation is not None)
    head = (f"#1=IFCGROUP('0everyProductGroup0000',$,'every product',$,$);\n"
            f"#2=IFCRELASSIGNSTOGROUP('0everyProductAssigned0',$,$,$,({products}),$,#1);\n")
    empty = ifcopenshell.file(schema_identifier=model.schema_identifier)
    text = empty.to_string().replace("DATA;\n", "DATA;\n" + head + body)
    return ifcopenshell.file.from_string(text)


MODELS = {"tunnel": lambda: tunnel_file(4, "IFC4", face_set="surface_model"),
          "tunnel reached backwards": lambda: _reached_backwards(tunnel_file(4, "IFC4", face_set="surface_model")),
          "tunnel IFC4X3": lambda: tunnel_file(2, "IFC4X3_ADD2", face_set="surface_model"),
          "zoo": lambda: build_model(zoo_spec("IFC4"))}


@pytest.mark.parametrize("name", list(MODELS))
@pytest.mark.parametrize("allow_mirror", [False, True])  # mirrored members fall back to mapped items
@pytest.mark.parametrize("rebuild", [True, False])
def test_made_once_gives_the_same_file_as_made_for_each_member(name, allow_mirror, rebuild):
    text, removed = shared_and_merged(MODELS[name](), "product_shape", None,
                                       allow_mirror=allow_mirror, rebuild=rebuild)
    model = MODELS[name]()
    shared = sharing.SharedPlacements(model)
    text_once, removed_once = shared_and_merged(model, "product_shape", shared,
                                       allow_mirror=allow_mirror, rebuild=rebuild)
    assert text_once == text
    assert list(removed_once.items()) == list(removed.items())
    if name.startswith("tunnel"):  # a ring's members share one placement: most were not made at all
        assert len(shared.skipped) > len(sharing.PLACEMENT_PARTS) * len(shared.groups)


def test_the_kept_placement_is_numbered_as_the_post_pass_keeps_it(monkeypatch):
    """The post-pass reaches a ring's members in its own order, not in the order their placements were made:
    keeping each placement under the numbers it was made with gives another file than main's."""
    text, _ = shared_and_merged(MODELS["tunnel reached backwards"](), "product_shape", None)
    model = MODELS["tunnel reached backwards"]()
    monkeypatch.setattr(sharing.SharedPlacements, "renumbered", lambda self, model, order, reached: order)
    text_first_made, _ = shared_and_merged(model, "product_shape", sharing.SharedPlacements(model))
    assert text_first_made != text


def test_pinned_placements_are_made_for_each_member():
    """IFC2X3: a placement places one product (``PlacesObject`` [1:1]); the post-pass never merges them."""
    assert not sharing.SharedPlacements.applies(tunnel_file(1, "IFC2X3"))
    assert sharing.SharedPlacements.applies(tunnel_file(1, "IFC4"))
