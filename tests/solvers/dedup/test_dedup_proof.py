"""The proof and the post-pass on their own (no solve): the semantic fingerprint sees a changed style
or property value, inherited validation errors are told from new ones, and the post-pass merges
duplicates but never against the schema's inverse cardinalities."""

from __future__ import annotations

import re
from collections import Counter

import ifcopenshell
import ifcopenshell.validate
import pytest

from plantsolve.solvers.dedup import (
    changes,
    postpass,
    proof,
    schemacheck,
    sharing,
    skeleton,
)
from plantsolve.solvers.dedup.synthetic import build_model, tunnel_file, zoo_spec
from plantsolve.solvers.dedup.solve import why_unverified
from tests.solvers.dedup.support import assert_round_trip, reopen, run


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


def _long_loop(loop_id: int, first_point_id: int):
    """An IFC4 file with one IfcPolyLoop (id ``loop_id``) of 150 points, one of them 2D: it breaks
    IfcPolyLoop.AllPointsSameDim, and its STEP line is longer than 500 characters."""
    model = ifcopenshell.file(schema="IFC4")
    points = [model.create_entity("IfcCartesianPoint", [float(k), 0.5, 0.25], id=first_point_id + k)
              for k in range(149)]
    points.append(model.create_entity("IfcCartesianPoint", [1.0, 1.0], id=first_point_id + 149))
    return model, model.create_entity("IfcPolyLoop", points, id=loop_id)


def test_the_same_error_on_ids_of_other_lengths_is_inherited():
    """'#18' against '#1018' (and points #100… against #2000…): the old comparison cut each message to
    500 characters before removing ids, so the two differed after the cut."""
    rules = proof.Rules("IFC4")
    found = {}
    for loop_id, first in ((18, 100), (1018, 2000)):
        model, loop = _long_loop(loop_id, first)
        (found[loop_id],) = schemacheck.rule_findings(model, [loop], rules)
    a, b = found[18], found[1018]
    assert a.rule == "IfcPolyLoop.AllPointsSameDim" and a.entity == "IfcPolyLoop"
    assert len(a.instance) > 500 and a.instance.startswith("#18=") and b.instance.startswith("#1018=")
    assert a.text(10_000)[:500] != b.text(10_000)[:500]  # what the cut used to compare
    assert a.key == b.key and not re.search(r"#\d", a.message)
    assert proof.inherited([b], [a]) and proof.inherited([a], [b])
    assert not proof.inherited([b, b], [a])  # as many times or more
    other = schemacheck.Finding("IfcPolyLoop.Other", "IfcPolyLoop", a.message)
    assert not proof.inherited([other], [a])  # another rule is another error
    assert not proof.inherited([schemacheck.Finding(a.rule, "IfcFaceBound", a.message)], [a])


def test_messages_are_normalised_before_any_cut():
    message = ("Rule IfcShapeModel.WR11:\n    (sizeof(SELF.OfProductRepresentation) == 1)\n"
               "Violated by:\n    #1018 <object at 0x7f11bb>\n\nOn instance:\n    #1018=IfcShapeRepresentation(#5,'Body')\n")
    assert schemacheck.normalised(message) == ("Rule IfcShapeModel.WR11:\n    (sizeof(SELF.OfProductRepresentation) == 1)"
                                               "\nViolated by:\n    # <object at 0x>")
    assert schemacheck.normalised(message.replace("#1018", "#18")) == schemacheck.normalised(message)


def test_the_part_checker_finds_what_ifcopenshell_validate_finds():
    """Schema checks, where-rules and global rules run here on a whole IFC2X3 model with errors of
    each kind give the library's errors, rule for rule and entity for entity."""
    model = build_model(zoo_spec("IFC2X3"))
    model.create_entity("IfcLocalPlacement", None, model.by_type("IfcAxis2Placement3D")[0])  # PlacesObject [1:1]
    model.by_type("IfcProduct")[3].OwnerHistory = None  # not optional in IFC2X3
    model.create_entity("IfcPolyLoop", [model.create_entity("IfcCartesianPoint", [0.0, 0.0]),
                                        *model.by_type("IfcCartesianPoint")[:2]])  # AllPointsSameDim
    logger = ifcopenshell.validate.json_logger()
    ifcopenshell.validate.validate(model, logger, express_rules=True)
    library = Counter((str(s.get("attribute") or ""), s["instance"].is_a() if s.get("instance") is not None else "")
                      for s in logger.statements if s["level"] == "error")
    ours = Counter((f.rule, f.entity) for f in proof.validate(model, express_rules=True))
    assert ours == library and len(library) >= 3
    assert ("IfcPolyLoop.WR21", "IfcPolyLoop") in ours or ("IfcPolyLoop.AllPointsSameDim", "IfcPolyLoop") in ours
    part = [i for i in model if i.is_a("IfcPolyLoop")]
    assert {f.entity for f in proof.findings(model, part, proof.Rules(model.schema_identifier))} == {"IfcPolyLoop"}


def test_the_diff_tells_changed_new_removed_and_re_referenced_instances(monkeypatch):
    """The input as another tool wrote it (blanks after '=', a line break inside an instance, other
    spellings of the same numbers) against the output as IfcOpenShell writes it."""
    before = ("ISO-10303-21;\nHEADER;\nFILE_SCHEMA(('IFC4'));\nENDSEC;\nDATA;\n#1= IFCA(#2,'x');\n"
              "#2= IFCB(1.00000000000E-5,.T.);\n#3= IFCC(#2);\n#4= IFCD(#1,\n  #2);\n#5= IFCE(#1);\n#6= IFCF(#2);\n"
              "#7= IFCG(#6);\n#9= IFCH('a;b',0.5);\nENDSEC;\nEND-ISO-10303-21;\n")
    after = ("ISO-10303-21;\nHEADER;\nFILE_SCHEMA(('IFC4'));\nENDSEC;\nDATA;\n#1=IFCA(#2,'x');\n"
             "#2=IFCB(1.E-05,.T.);\n#3=IFCC(#1);\n#4=IFCD(#1,#2);\n#6=IFCF(#2);\n#7=IFCG(#6);\n"
             "#9=IFCH('a;B',0.5);\n#1000=IFCI(#9);\nENDSEC;\nEND-ISO-10303-21;\n")
    for size in (1 << 22, 8):  # one piece, and a piece per instance
        monkeypatch.setattr(changes, "CHUNK_CHARS", size)
        d = changes.diff(before, after)
        # #3 refers to #1 instead of #2; #9's string differs; #5 (referring to #1) is gone
        assert (d.changed, d.new, d.removed, d.unchanged) == ({3, 9}, {1000}, {5}, 5)
        assert d.rewired == {1, 2}  # #1: one referrer lost, one gained (#3); #2: #3 lost
    assert changes.same_values("IFCX(1.,'A', .T.)", "ifcx(1.0,'A',.T.)")
    assert not changes.same_values("IFCX('a')", "IFCX('A')") and not changes.same_values("IFCX(1.)", "IFCX(1.5)")
    assert not changes.same_values("IFCX(#1)", "IFCX(#10)") and not changes.same_values("IFCX(1)", "IFCX(1,$)")


def _same_changes(a: changes.Changes, b: changes.Changes) -> bool:
    return (a.changed, a.new, a.rewired, a.unchanged, a.removed) == (b.changed, b.new, b.rewired, b.unchanged, b.removed)


def test_the_scans_index_tells_the_same_changes_as_the_whole_input(tmp_path):
    """The proof's comparison through the scan's index of the input's lines (only the output's ids read, the
    references counted by the scan, a '#3' in a string too) against the comparison with the whole input text."""
    before = ("ISO-10303-21;\nHEADER;\nFILE_SCHEMA(('IFC4'));\nENDSEC;\nDATA;\n#1= IFCA(#2,'x');\n"
              "#2= IFCB(1.00000000000E-5,.T.);\n#3= IFCC(#2);\n#4= IFCD(#1,#2);\n#5= IFCE(#1);\n#6= IFCF(#2,'#3');\n"
              "#7= IFCG(#6);\n#9= IFCH('a;b',0.5);\nENDSEC;\nEND-ISO-10303-21;\n")
    after = ("ISO-10303-21;\nHEADER;\nFILE_SCHEMA(('IFC4'));\nENDSEC;\nDATA;\n#1=IFCA(#2,'x');\n"
             "#2=IFCB(1.E-05,.T.);\n#3=IFCC(#1);\n#4=IFCD(#1,#2);\n#6=IFCF(#2,'#3');\n#7=IFCG(#6);\n"
             "#9=IFCH('a;B',0.5);\n#1000=IFCI(#9);\nENDSEC;\nEND-ISO-10303-21;\n")
    path = tmp_path / "before.ifc"
    path.write_text(before)
    indexed = changes.diff_indexed(skeleton.read(path).index, after)
    assert (indexed.changed, indexed.new, indexed.removed, indexed.rewired) == ({3, 9}, {1000}, {5}, {1, 2})
    assert _same_changes(indexed, changes.diff(before, after))
    # a solved tunnel: its output against its input, both ways
    model = tunnel_file(3, "IFC4")
    model.write(str(path))
    solved = run(model, sharing="product_shape")
    written = solved.files["optimized.ifc"].decode("latin-1")
    indexed = changes.diff_indexed(skeleton.read(path).index, written)
    assert indexed.changed and indexed.new and indexed.rewired
    assert _same_changes(indexed, changes.diff(path.read_bytes().decode("latin-1"), written))


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


def _without_placements(model: ifcopenshell.file) -> ifcopenshell.file:
    """The tunnel's segments (meshes baked into world coordinates) without any placement, as world-baked
    exports write them: every one breaks IFC4's IfcProduct.PlacementForShapeRepresentation."""
    for product in model.by_type("IfcBuildingElementProxy"):
        placement, product.ObjectPlacement = product.ObjectPlacement, None
        model.remove(placement.RelativePlacement)
        model.remove(placement)
    return model


@pytest.fixture(params=["changed part", "whole output"])
def proof_scope(request, monkeypatch):
    """Both ways the proof validates: the part that changed (the scan's index of the input's lines tells it),
    or, for an input the scan did not index, the whole output when it is far smaller than its input (the input
    then read whole only when the output has errors)."""
    monkeypatch.setattr(proof, "WHOLE_OUTPUT_BELOW", 0.0 if request.param == "changed part" else 10.0)
    if request.param == "whole output":
        verdict = proof.verdict
        monkeypatch.setattr(proof, "verdict", lambda check, written, path, rules, index=None:
                            verdict(check, written, path, rules))
    return request.param


def test_a_world_baked_model_without_placements_keeps_its_own_errors_and_is_offered(proof_scope):
    model = _without_placements(tunnel_file(2, "IFC4"))
    errors = proof.validate(model, express_rules=True)
    assert {(e.rule, e.entity) for e in errors} == {
        ("IfcProduct.PlacementForShapeRepresentation", "IfcBuildingElementProxy")} and len(errors) == 16
    solved = run(model, sharing="mapped_item")  # members keep no placement: the same error on each
    v = solved.result.verification
    assert solved.result.products_shared == 8
    assert_round_trip(model, solved, inherited=True)
    assert len(v.validation_errors) == 16 and all("PlacementForShapeRepresentation" in e for e in v.validation_errors)
    assert any(w.code == "input_invalid" for w in solved.result.report.warnings)
    # a shared product shape puts each member's transform into a new placement: fewer errors, still the input's
    solved = run(model, sharing="product_shape")
    v = solved.result.verification
    assert "optimized.ifc" in solved.files and v.errors_inherited and len(v.validation_errors) == 8


def test_a_new_inverse_error_from_sharing_is_caught_and_the_file_withheld(monkeypatch, proof_scope):
    """IFC2X3 allows one product per IfcProductDefinitionShape (ShapeOfProduct [1:1]): sharing one
    anyway breaks the shape's inverse, on an instance whose own STEP line did not change."""
    apply = sharing.apply
    monkeypatch.setattr(sharing, "apply", lambda model, classes, mode, **kw: apply(model, classes, "product_shape", **kw))
    model = tunnel_file(2, "IFC2X3")
    solved = run(model, sharing="mapped_item")
    v = solved.result.verification
    assert solved.result.report.details["written"]["shared_product_shapes"] == 8
    assert "optimized.ifc" not in solved.files and not v.errors_inherited and not v.schema_valid
    assert v.semantic_counts_equal and v.max_deviation <= 1e-5  # only the validation sees it
    assert sum("IfcProductDefinitionShape.ShapeOfProduct" in e for e in v.validation_errors) == 8
    assert any(w.code == "verification_failed" for w in solved.result.report.warnings)
    # nothing to deliver: the report fails (the job with it), naming what was found, its details the verification
    report = solved.result.report
    assert report.status == "failed" and report.stage == "verification"
    assert "8 validation error(s)" in report.message and "ShapeOfProduct" in report.message
    assert report.details["verification"]["schema_valid"] is False


def test_a_new_rule_error_on_a_written_instance_is_caught_even_when_the_input_had_errors(monkeypatch, proof_scope):
    """A mapped representation called 'Brep' breaks IfcShapeRepresentation.CorrectItemsForType; the
    input's own errors (segments without placement) do not cover it."""
    apply = sharing.apply

    def mislabelled(model, classes, mode, **kw):
        written = apply(model, classes, mode, **kw)
        for rep in model.by_type("IfcShapeRepresentation"):
            if rep.RepresentationType == "MappedRepresentation":
                rep.RepresentationType = "Brep"
                break
        return written

    monkeypatch.setattr(sharing, "apply", mislabelled)
    model = _without_placements(tunnel_file(2, "IFC4"))
    solved = run(model, sharing="mapped_item")
    v = solved.result.verification
    assert "optimized.ifc" not in solved.files and not v.errors_inherited
    assert sum("CorrectItemsForType" in e for e in v.validation_errors) == 1
    assert sum("PlacementForShapeRepresentation" in e for e in v.validation_errors) == 16


def test_the_proof_validates_what_changed_not_the_whole_file(proof_scope):
    model = tunnel_file(3, "IFC4")
    orphan = model.create_entity("IfcCartesianPoint", [0.0, 0.0])  # unused, untouched: the input's business
    model.create_entity("IfcPolyLoop", [orphan, *model.by_type("IfcCartesianPoint")[:2]])  # AllPointsSameDim
    solved = run(model, sharing="mapped_item", postpass=False)
    v = solved.result.verification
    out = reopen(solved)
    total = len(list(out))
    # a whole-file check of the output finds only the input's loop
    assert {(e.rule, e.entity) for e in proof.validate(out, express_rules=True)} == {
        ("IfcPolyLoop.AllPointsSameDim", "IfcPolyLoop")}
    assert "optimized.ifc" in solved.files
    if proof_scope == "changed part":  # the loop is not looked at again
        assert v.schema_valid and not v.validation_errors and not v.errors_inherited
        assert 0 < v.instances_changed <= v.instances_validated < total / 2, (v, total)
    else:  # seen, and known for the input's own: it is on an instance the optimization left as it was
        assert not v.schema_valid and v.errors_inherited and len(v.validation_errors) == 1
        assert "AllPointsSameDim" in v.validation_errors[0] and v.instances_validated == total
        assert 0 < v.instances_changed < total  # errors found: what changed was looked up to judge them
    if proof_scope == "whole output":  # a clean output validated whole never reads the input again
        solved = run(tunnel_file(3, "IFC4"), sharing="mapped_item", postpass=False)
        v = solved.result.verification
        assert v.schema_valid and v.instances_changed is None and v.instances_validated == len(list(reopen(solved)))


def test_a_gained_style_is_named_and_a_failed_verification_is_always_said_in_words():
    before = {"rooted": {}, "guids": set(), "properties": {}, "styles": {}}
    after = {**before, "styles": {"2LCKQSQwj9leW7M2$719un": ("red",)}}
    assert proof.fingerprint_differences(before, after) == [
        "1 product(s) with other styles, e.g. 2LCKQSQwj9leW7M2$719un"]
    assert "semantic fingerprint differs" in why_unverified([], [], None, 1e-3)  # was a TypeError: a crash
    assert "semantic fingerprint differs" in why_unverified([], [], 2e-4, 1e-3)  # was 'beyond the tolerance'
    assert "beyond the tolerance" in why_unverified([], [], 2e-3, 1e-3)
