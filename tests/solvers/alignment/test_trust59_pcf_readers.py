"""PCF patterns of files that other tools write, found in public PCF viewers' sample files (their patterns reproduced
here, the files themselves carry no licence):

- the header's ``UNITS-BORE`` / ``UNITS-CO-ORDS`` records indented under ``PIPELINE-REFERENCE``: passed over, 4 in
  bores were read as 4 mm and the file was said to state no unit;
- a BEND whose CENTRE-POINT lies midway between its END-POINTs (a return bend's points) with ``ANGLE 90``: aligned
  as a 180 degree bend without a word of its record;
- a 0.4 mm PIPE between a flange and a bend (exporters fill such gaps with pipes): said to be an END-POINT typed
  twice whose far item was left open, when both its neighbours are joined.
"""

import pytest

from plantsolve.solvers.alignment.pcf import interpret_pcf
from plantsolve.solvers.alignment.upload import parse_upload
from plantsolve.solvers.base import InputRejected, StoredInput

ROUTE = ("PIPE\n    END-POINT 0.0000 0.0000 0.0000 4.0000\n    END-POINT 1000.0000 0.0000 0.0000 4.0000\n"
         "BEND\n    END-POINT 1000.0000 0.0000 0.0000 4.0000\n    END-POINT 1152.4000 152.4000 0.0000 4.0000\n"
         "    CENTRE-POINT 1152.4000 0.0000 0.0000\n"
         "PIPE\n    END-POINT 1152.4000 152.4000 0.0000 4.0000\n    END-POINT 1152.4000 1152.4000 0.0000 4.0000\n")
INDENTED = "PIPELINE-REFERENCE LINE-100\n    PIPING-SPEC CS150\n    UNITS-BORE INCH\n    UNITS-CO-ORDS MM\n\n" + ROUTE


def _read(text: str):
    return parse_upload(StoredInput.from_bytes("line.pcf", text.encode()), None)


def _warnings(text: str) -> dict:
    return {code: details for code, _, details, level in interpret_pcf(text, {}).notes if level == "warning"}


def test_units_records_indented_under_the_pipeline_reference_are_the_files():
    request = _read(INDENTED)
    assert [c.radius for c in request.components] == pytest.approx([2.0 * 25.4] * 3)  # 4 in bores: radius in mm
    assert request.units == "mm"
    assert not {"pcf_units_assumed", "pcf_bore_units"} & set(_warnings(INDENTED))
    # the same file with its header at the margin reads the same
    flush = INDENTED.replace("    UNITS-", "UNITS-")
    assert [c.radius for c in _read(flush).components] == [c.radius for c in request.components]


@pytest.mark.parametrize(("header", "said"), [
    ("    UNITS-CO-ORDS FURLONG\n", "line 3: UNITS-CO-ORDS 'FURLONG' is no unit"),
    ("    UNITS-CO-ORDS MM\nUNITS-CO-ORDS INCH\n", "line 3: MM, line 4: INCH"),
])
def test_indented_units_records_are_refused_as_the_margins_are(header, said):
    with pytest.raises(InputRejected) as refused:
        _read("PIPELINE-REFERENCE LINE-100\n    PIPING-SPEC CS150\n" + header + ROUTE)
    (error,) = refused.value.errors
    assert error.loc == ("file",) and said in error.msg


def test_a_units_record_of_an_item_is_no_header():
    # an item's own indented record is its attribute, not the file's unit
    text = "UNITS-BORE MM\nUNITS-CO-ORDS MM\n" + ROUTE.replace(
        "PIPE\n    END-POINT 0.0000", "PIPE\n    UNITS-BORE INCH\n    END-POINT 0.0000", 1).replace(" 4.0000", " 100.0000")
    assert {c.radius for c in _read(text).components} == {50.0}


RETURN = ("UNITS-BORE MM\nUNITS-CO-ORDS MM\n"
          "PIPE\n    END-POINT 0.0 0.0 0.0 400.0\n    END-POINT 2000.0 0.0 0.0 400.0\n"
          "BEND\n    END-POINT 2000.0 0.0 0.0 400.0\n    END-POINT 2000.0 1000.0 0.0 400.0\n"
          "    CENTRE-POINT 2000.0 500.0 0.0\n    ANGLE {angle}\n    BEND-RADIUS 500.0\n"
          "PIPE\n    END-POINT 2000.0 1000.0 0.0 400.0\n    END-POINT 0.0 1000.0 0.0 400.0\n")


def test_an_angle_record_a_return_bends_points_contradict_is_named():
    (found,) = _warnings(RETURN.format(angle="90.0"))["pcf_records_contradict_points"]["records"]
    assert (found["record"], found["record_line"], found["value"], found["read_as"], found["from_points"]) == (
        "ANGLE", 10, "90.0", 90.0, 180.0)
    assert found["id"] == "BEND-2"


@pytest.mark.parametrize("angle", ["180", "18000", "180.0"])
def test_a_return_bends_own_angle_is_no_contradiction(angle):
    assert "pcf_records_contradict_points" not in _warnings(RETURN.format(angle=angle))


FILLER = ("UNITS-BORE MM\nUNITS-CO-ORDS MM\n"
          "FLANGE\n    END-POINT 0.0000 -263.8250 0.0000 152.4000\n    END-POINT 0.0000 -413.0490 0.0000 152.4000\n"
          "PIPE\n    END-POINT 0.0000 -413.0490 0.0000 152.4000\n    END-POINT 0.0000 -413.4490 0.0000 152.4000\n"
          "BEND\n    END-POINT 0.0000 -413.4490 0.0000 152.4000\n    END-POINT -228.6000 -642.0490 0.0000 152.4000\n"
          "    CENTRE-POINT 0.0000 -642.0490 0.0000\n"
          "PIPE\n    END-POINT -228.6000 -642.0490 0.0000 152.4000\n    END-POINT -1228.6000 -642.0490 0.0000 152.4000\n")


def test_a_short_pipe_between_two_items_is_no_end_point_typed_twice():
    assert "pcf_zero_length_pipe" not in _warnings(FILLER)


def test_a_short_pipe_whose_far_end_meets_nothing_is_still_named():
    # the bend moved 20 mm on: the 0.4 mm pipe's far end meets nothing, the bend's near end is left open
    moved = FILLER.replace("-413.4490 0.0000 152.4000\n    END-POINT -228.6000", "-433.4490 0.0000 152.4000\n"
                           "    END-POINT -228.6000")
    (found,) = _warnings(moved)["pcf_zero_length_pipe"]["items"]
    assert found["id"] == "PIPE-2" and found["length"] == pytest.approx(0.4)


ELBOW = ("UNITS-BORE MM\nUNITS-CO-ORDS MM\n"
         "PIPE\n    END-POINT 0.0 0.0 0.0 100.0\n    END-POINT 1000.0 0.0 0.0 100.0\n"
         "ELBOW\n    END-POINT 1000.0 0.0 0.0 100.0\n    END-POINT 1152.4 152.4 0.0 100.0\n"
         "    CENTRE-POINT 1152.4 0.0 0.0\n    BEND-RADIUS {radius}\n"
         "PIPE\n    END-POINT 1152.4 152.4 0.0 100.0\n    END-POINT 1152.4 1152.4 0.0 100.0\n")


@pytest.mark.parametrize("radius", ["0", "-152.4", "nan"])
def test_a_bend_radius_record_that_is_no_positive_number_is_named(radius):
    # before: passed over as if the file had none, without a word
    (found,) = _warnings(ELBOW.format(radius=radius))["pcf_records_contradict_points"]["records"]
    assert (found["record"], found["record_line"], found["value"], found["read_as"]) == ("BEND-RADIUS", 10, radius, None)
    assert found["from_points"] == pytest.approx(152.4)


@pytest.mark.parametrize("radius", ["152.4", "LR"])
def test_a_bend_radius_the_points_agree_with_or_a_word_is_not_named(radius):
    assert "pcf_records_contradict_points" not in _warnings(ELBOW.format(radius=radius))


def test_a_return_bends_radius_record_of_zero_is_named():
    (found,) = _warnings(RETURN.format(angle="180").replace("BEND-RADIUS 500.0", "BEND-RADIUS 0"))[
        "pcf_records_contradict_points"]["records"]
    assert (found["record"], found["value"], found["from_points"]) == ("BEND-RADIUS", "0", 500.0)
