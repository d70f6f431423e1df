"""The proof and the post-pass on their own (no solve): the semantic fingerprint sees a changed style
or property value, inherited validation errors are told from new ones, and the post-pass merges
duplicates but never against the schema's inverse cardinalities."""

from __future__ import annotations

from collections import Counter

from plantsolve.solvers.dedup import postpass, proof
from plantsolve.solvers.dedup.synthetic import build_model, tunnel_file, zoo_spec


def test_the_fingerprint_sees_a_restyled_product_and_a_changed_property():
    model = build_model(zoo_spec("IFC4"))
    before = proof.semantic_fingerprint(model)
    assert proof.semantic_fingerprint(model) == before
    column = next(p for p in model.by_type("IfcColumn") if p.Name == "column_a")
    red_column = next(p for p in model.by_type("IfcColumn") if p.Name == "column_red")
    red = next(s for s in model.by_type("IfcStyledItem") if s.Item == red_column.Representation.Representations[0].Items[0])
    model.create_entity("IfcStyledItem", column.Representation.Representations[0].Items[0], red.Styles, None)
    after = proof.semantic_fingerprint(model)
    assert after != before and after["styles"][column.GlobalId] == before["styles"][
        next(p for p in model.by_type("IfcColumn") if p.Name == "column_red").GlobalId]
    model = tunnel_file(2, "IFC4")
    before = proof.semantic_fingerprint(model)
    model.by_type("IfcPropertySingleValue")[0].NominalValue = model.create_entity("IfcInteger", 99)
    assert proof.semantic_fingerprint(model) != before


def test_inherited_errors_ignore_ids_and_addresses_but_count():
    old = ["#12=IfcLocalPlacement($,#3): PlacesObject <object at 0x7f00aa>"]
    assert proof.inherited(["#99=IfcLocalPlacement($,#4): PlacesObject <object at 0x7f11bb>"], old)
    assert not proof.inherited(["#99=IfcLocalPlacement($,#4): PlacesObject <object at 0x7f11bb>"] * 2, old)
    assert not proof.inherited(["#5=IfcShapeRepresentation: WR11"], old)


def test_the_post_pass_respects_inverse_cardinalities_of_ifc2x3_and_ifc4():
    for schema in ("IFC2X3", "IFC4"):
        model = tunnel_file(2, schema)
        products = model.by_type("IfcProduct")
        placements_before = len(model.by_type("IfcLocalPlacement"))
        removed = postpass.merge_identical(model)
        assert removed.get("IfcDirection", 0) > 0  # identical directions merged
        placements = Counter(p.ObjectPlacement.id() for p in products if p.ObjectPlacement is not None)
        if schema == "IFC2X3":  # PlacesObject [1:1]: every product keeps its own placement
            assert max(placements.values()) == 1 and "IfcLocalPlacement" not in removed
            assert len(model.by_type("IfcLocalPlacement")) == placements_before
        else:  # IFC4 allows shared placements: the segments' identical ones merge
            assert max(placements.values()) > 1 and removed["IfcLocalPlacement"] > 0
        assert not proof.validate(model, express_rules=False)


def test_fingerprint_differences_name_what_changed():
    from plantsolve.solvers.dedup.proof import fingerprint_differences

    before = {"rooted": {"IfcBeam": 2, "IfcWall": 1}, "guids": {"a", "b", "c"},
              "properties": {("Width", "0.2"): 2}, "styles": {"a": ("red",), "b": ("red",)}}
    assert fingerprint_differences(before, before) == []
    after = {"rooted": {"IfcBeam": 2}, "guids": {"a", "b"}, "properties": {("Width", "0.2"): 1},
             "styles": {"a": ("red",), "b": ()}}
    said = fingerprint_differences(before, after)
    assert said == ["IfcWall: 1 rooted instance(s) before, 0 after", "1 GlobalId(s) lost, e.g. c",
                    "property Width 0.2: 2 before, 1 after", "1 product(s) with other styles, e.g. b"]


def test_the_fingerprint_compares_what_each_property_set_holds_not_instance_counts():
    """Two property sets may share one identical property instance (IFC4): the post-pass does that
    to real exports (an ArchiCAD file repeats 'AirConditioning' .F. in seven sets)."""
    model = tunnel_file(2, "IFC4")
    psets = model.by_type("IfcPropertySet")
    for pset in psets[:2]:
        pset.HasProperties = [*pset.HasProperties, model.create_entity(
            "IfcPropertySingleValue", "AirConditioning", None, model.create_entity("IfcBoolean", False), None)]
    before = proof.semantic_fingerprint(model)
    first, second = psets[0].HasProperties[-1], psets[1].HasProperties[-1]
    psets[1].HasProperties = [*psets[1].HasProperties[:-1], first]
    model.remove(second)
    assert proof.semantic_fingerprint(model) == before
    psets[1].HasProperties = psets[1].HasProperties[:-1]  # a set that lost a property is a change
    assert proof.fingerprint_differences(before, proof.semantic_fingerprint(model)) == [
        "property AirConditioning IfcBoolean(.F.): 2 before, 1 after"]
