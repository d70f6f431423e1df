"""An IFC file cut mid-entity is read as far as the cut (``truncated_file``), but its totals read as the building's:
'2 of 2 zone(s) closed', 108 m³, no verdict, for a file naming three spaces before the cut and a fourth its storey
aggregates past it. The report's verdict is NOT DETERMINED (``totals_not_determined``), naming the spaces the file
names, those not measured and the objects past the cut; the summary says the totals are those read."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from plantsolve.schemas.polyhedra import PolyhedraRequest
from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.polyhedra.ifc_cut import aggregated_past_cut
from plantsolve.solvers.polyhedra.solve import solve
from plantsolve.solvers.polyhedra.upload import parse_upload
from plantsolve.solvers.step_file import (
    TRAILER_BYTES,
    blank_strings_and_comments,
    holds_every_instance,
    where_cut,
)

IFC = (Path(__file__).parent / "data/ifcopenshell_spaces.ifc").read_text()


def solved(text: str):
    return solve(parse_upload(StoredInput.from_bytes("spaces.ifc", text.encode()), None)).result


def cut_inside(number: int, text: str = IFC) -> str:
    """The file cut in the middle of entity ``#number``'s line."""
    at = text.index(f"\n#{number}=") + 1
    return text[:at + (text.index("\n", at) - at) // 2]


def test_a_cut_ifc_whose_storey_aggregates_a_space_past_the_cut_is_not_determined():
    result = solved(cut_inside(60))  # #18, #37, #54 named ('103' without its body); #67 aggregated, past the cut
    assert [z.id for z in result.zones] == ["101", "102"] and result.total_volume == pytest.approx(108.0)
    assert result.report.verdict.code == "totals_not_determined" and result.report.verdict.label == "NOT DETERMINED"
    (verdict,) = [w for w in result.report.warnings if w.code == "totals_not_determined"]
    assert verdict.details["spaces_named"] == 3 and verdict.details["spaces_measured"] == 2
    assert verdict.details["spaces_not_measured"] == ["#54 IfcSpace '103'"] and verdict.details["objects_past_cut"] == 1
    assert "truncated_file" in {w.code for w in result.report.warnings}
    assert result.report.message == ("2 of 2 zone(s) closed; the file was cut short: it names 3 space(s) and 1 "
                                     "object(s) past the cut, the totals are those of the 2 read")


def test_relations_written_after_the_cut_count_no_object_past_it_and_the_totals_still_are_not_determined():
    # as Revit writes them, the storey's aggregation last: nothing in the file names what lies past the cut
    relation = next(line for line in IFC.splitlines(keepends=True) if line.startswith("#19=IFCRELAGGREGATES"))
    result = solved(cut_inside(60, IFC.replace(relation, "")))
    (verdict,) = [w for w in result.report.warnings if w.code == "totals_not_determined"]
    assert verdict.details["objects_past_cut"] == 0 and verdict.details["spaces_named"] == 3
    assert "cannot be counted" in verdict.message and result.report.verdict.code == "totals_not_determined"


def test_the_whole_file_and_one_missing_only_its_trailer_are_determined():
    assert solved(IFC).report.verdict is None
    trailer_lost = IFC[:IFC.rindex("END-ISO-10303-21;")]  # every instance and 'ENDSEC;' there: nothing lost
    result = solved(trailer_lost)
    assert result.report.verdict is None and "truncated_file" in {w.code for w in result.report.warnings}


@pytest.mark.parametrize("tail", ["END-ISO-10303-21", "END-ISO-1", "E", "\x00" * 64, "\x1a", "END-ISO-10303-21;\x00\x00"])
def test_a_file_missing_part_of_its_trailer_or_padded_after_it_is_determined(tail):
    text = IFC[:IFC.rindex("END-ISO-10303-21;")] + tail
    assert holds_every_instance(blank_strings_and_comments(text))
    assert solved(text).report.verdict is None


def test_a_file_cut_before_its_data_section_ends_does_not_hold_every_instance():
    before_endsec = IFC[:IFC.rindex("ENDSEC;")]  # the header's ENDSEC; followed by DATA; is the last one left
    assert not holds_every_instance(blank_strings_and_comments(before_endsec))
    assert not holds_every_instance(blank_strings_and_comments(cut_inside(60)))


class _Model:
    """Instances #1..#10 held, those past them cut off; every one a spatial element."""

    def by_id(self, number):
        if number > 10:
            raise RuntimeError("no instance")
        return self

    def is_a(self, kind):
        return True


def test_aggregations_written_one_after_another_on_one_line_are_each_counted():
    text = ("HEADER;ENDSEC;DATA;#1=IFCRELAGGREGATES('a',$,$,$,#2,(#30,#3));#4=IFCRELAGGREGATES('b',$,$,$,#2,(#31));"
            "#5=IFCRELAGGREGATES('c',$,$,$,#2,(#30,#32));")
    assert aggregated_past_cut(text, _Model()) == 3  # #30, #31, #32



@pytest.mark.parametrize("cut", [{}, "yes", {"format": "IFC", "line": 3, "spaces_named": "x", "spaces_measured": 1,
                                              "spaces_not_measured": 5, "objects_past_cut": 0}])
def test_a_json_bodys_own_read_to_cut_of_another_shape_is_ignored(cut):
    # 'source' is free in a JSON body: only the IFC reader's shape of read_to_cut gives the verdict
    body = {**json.loads((Path(__file__).parents[3] / "examples/polyhedra/gable_house.json").read_text()),
            "source": {"read_to_cut": cut}}
    result = solve(PolyhedraRequest.model_validate(body)).result
    assert result.report.verdict is None and result.report.status == "ok"


def test_a_whole_file_with_comments_after_its_trailer_is_not_cut_and_a_lost_trailer_says_every_instance_is_there():
    # review: two comments after 'END-ISO-10303-21;' read as "stops inside entity #67" (dedup refused such a file),
    # and a file missing only part of its trailer was said to lack the spaces after the cut while its totals stood
    commented = IFC.rstrip() + "\n/* exported */\n/* checked */\n"
    assert where_cut(commented[-TRAILER_BYTES:].encode()) is None
    assert not [w for w in solved(commented).report.warnings if w.code == "truncated_file"]
    trailer_cut = IFC.rstrip()[:-8]
    said = where_cut(trailer_cut[-TRAILER_BYTES:].encode())
    assert said is not None and "every instance there" in said and "#" not in said
    result = solved(trailer_cut)
    (cut,) = [w for w in result.report.warnings if w.code == "truncated_file"]
    assert "Every instance is there" in cut.message and "are missing" not in cut.message
    assert result.report.verdict is None and result.total_volume == pytest.approx(solved(IFC).total_volume)
