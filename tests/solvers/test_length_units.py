"""One length-unit vocabulary (solvers/length_units.py): every reader accepts at least the spellings its own table
took before (listed here as they were), and now the same words as the others (which each used to refuse or skip)."""

from typing import get_args

import pytest

from plantsolve.schemas.common import UnitName
from plantsolve.solvers.flowmeter.field_file import FieldFileError, read_field_file
from plantsolve.solvers.length_units import METRES, SIZES, spellings, unit_named, unit_of_size
from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.perfmap.upload import parse_upload
from plantsolve.solvers.polyhedra.file_units import symbol
from plantsolve.solvers.tube.las_units import US_SURVEY_FOOT_M, short_name
from plantsolve.solvers.tube.ply_points import stated_unit
from plantsolve.solvers.tube.read_log import ReadLog
from plantsolve.solvers.tube.text_points import read_text_points

# each reader's spellings on main (its own table), by the unit they name
TEXT_HEADER_BEFORE = {"mm": "mm", "cm": "cm", "m": "m", "in": "in", "inch": "in", "ft": "ft", "feet": "ft"}
PLY_BEFORE = {"mm": "mm", "millimeter": "mm", "millimeters": "mm", "millimetre": "mm", "millimetres": "mm",
              "cm": "cm", "centimeter": "cm", "centimeters": "cm", "centimetre": "cm", "centimetres": "cm",
              "m": "m", "meter": "m", "meters": "m", "metre": "m", "metres": "m",
              "in": "in", "inch": "in", "inches": "in", "ft": "ft", "foot": "ft", "feet": "ft"}
FIELD_FILE_BEFORE = {"m": 1.0, "cm": 1e-2, "mm": 1e-3, "um": 1e-6, "µm": 1e-6, "μm": 1e-6, "in": 0.0254, "ft": 0.3048}
PERFMAP_BEFORE = {"mm", "cm", "m", "in", "inch", "ft"}
# what every reader of the request's units takes now: the union of the above
WORDS = {**TEXT_HEADER_BEFORE, **PLY_BEFORE}


def test_the_vocabulary_names_the_request_units_and_their_sizes():
    assert set(METRES) == set(get_args(UnitName))
    assert dict(METRES) == {"mm": 1e-3, "cm": 1e-2, "m": 1.0, "in": 0.0254, "ft": 0.3048}
    assert SIZES["um"] == 1e-6 and unit_named("um") is None and unit_named("Microns", SIZES) == "um"
    assert {word: unit_named(word.upper()) for word in WORDS} == WORDS
    assert unit_named("furlong") is None and unit_named("") is None and unit_named("-") is None
    assert spellings() == set(WORDS)
    assert unit_of_size(0.0254) == "in" and unit_of_size(0.3048 * (1 + 1e-12)) == "ft"
    assert unit_of_size(US_SURVEY_FOOT_M) is None and unit_of_size(1e-6) is None and unit_of_size(1e-6, SIZES) == "um"


def _text_unit(text: str) -> str | None:
    points, columns = read_text_points(text.encode(), ReadLog("csv"))
    assert points.tolist() == [[1, 2, 3], [4, 5, 6]]
    return columns.unit


@pytest.mark.parametrize("word", sorted(WORDS))
def test_a_tube_text_header_reads_every_word(word):
    # before: 'millimetres', 'meter', 'inches', 'foot' ... were refused ("not a length unit read here"), and a line
    # of them under the names was taken for the header ("no x, y, z")
    assert _text_unit(f"x [{word}],y [{word}],z [{word}]\n1,2,3\n4,5,6\n") == WORDS[word]
    assert _text_unit(f"x,y,z\n{word},{word},{word}\n1,2,3\n4,5,6\n") == WORDS[word]


def _refusal(text: str) -> str:
    with pytest.raises(InputRejected) as refused:
        read_text_points(text.encode(), ReadLog("csv"))
    return refused.value.errors[0].msg


def test_a_tube_text_header_still_refuses_what_is_no_length_unit_listing_the_units():
    assert _refusal("x [deg],y [deg],z [deg]\n1,2,3\n") == ("line 1: the coordinate columns state the unit 'deg', "
                                                             "which is not a length unit read here (mm, cm, m, in, ft, um)")
    assert "states the unit 'millimetres' in its name and 'in'" in _refusal("x [millimetres],y,z\nin,in,in\n1,2,3\n")


@pytest.mark.parametrize("word", sorted(PLY_BEFORE))
def test_a_ply_comment_reads_what_it_did(word):
    assert stated_unit(f"ply\nformat ascii 1.0\ncomment units {word.upper()}\nend_header\n".encode())[0] == PLY_BEFORE[word]


def test_a_ply_comment_in_micrometres_is_read_though_no_request_has_that_unit():
    assert stated_unit(b"ply\nformat ascii 1.0\ncomment units microns\nend_header\n")[0] == "um"


FIELD = "x [{u}], y [{u}], z [{u}], Bx [T], By [T]\n1, 2, 3, 0.1, 0.2\n"


@pytest.mark.parametrize("word", sorted({*FIELD_FILE_BEFORE, *WORDS, "micrometres", "microns", "MICRONS"}))
def test_a_field_file_reads_every_spelling_with_its_factor(word):
    # before: the words ('millimetres', 'inches', 'microns' ...) were "not known (m, cm, mm, um, in, ft)"
    table = read_field_file(FIELD.format(u=word), "m")
    expected = FIELD_FILE_BEFORE.get(word) or METRES.get(WORDS.get(word, "")) or 1e-6
    assert table.rows[0, :3] == pytest.approx([expected, 2 * expected, 3 * expected], rel=1e-12)


def test_a_field_file_with_micro_sign_and_greek_mu_states_one_unit():
    # before: 'µm' and 'μm' were two units ("the coordinates are given in µm and μm: which is meant is not known")
    text = "% Length unit: µm\n% x (μm) y (μm) z (μm) Bx (T) By (T)\n1 2 3 0.1 0.2\n"
    table = read_field_file(text, "mm")
    assert table.length_unit == "um" and table.rows[0, 0] == pytest.approx(1e-3, rel=1e-12)
    with pytest.raises(FieldFileError, match=r"length unit 'parsec' is not known \(m, cm, mm, um, in, ft\)"):
        read_field_file(FIELD.format(u="parsec"), "m")


@pytest.mark.parametrize("word", sorted(WORDS))
def test_a_tube_bending_table_sent_to_perfmap_is_named_whatever_length_word_its_columns_end_in(word):
    # before: 'length_meters' was a column 'length meters', and the table got the generic header message
    assert PERFMAP_BEFORE <= spellings()
    table = StoredInput.from_bytes("bends.csv", f"length_{word},rotation,angle_deg\n100,0,90\n200,90,45\n".encode())
    with pytest.raises(InputRejected) as refused:
        parse_upload(table, None)
    assert refused.value.errors[0].msg.startswith(
        "this file holds a tube's bending table (columns angle, length, rotation) (for tube), not a compressor map")


def test_sizes_are_named_as_before():
    assert [short_name("x", m) for m in (1.0, 0.3048, US_SURVEY_FOOT_M, 0.001, 0.01, 0.0254, 1000.0)] == \
        ["m", "ft", "us_ft", "mm", "cm", "in", "x"]
    assert [symbol(m) for m in (0.001, 0.3048, 0.9144)] == ["mm", "ft", "0.9144 m"]
