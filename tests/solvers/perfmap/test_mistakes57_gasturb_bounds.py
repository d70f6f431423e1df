"""A GasTurb/GSP map holding a number beyond any map's (``1e308`` typed for a missing value, a run-away export) is
refused naming its line; it crashed the reader (a 422 saying only that the file is malformed). A map of blank lines
is refused saying so (it was said to look like JSON)."""

from __future__ import annotations

import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.perfmap.upload import parse_upload
from tests.solvers.perfmap.test_perfmap_gasturb import closed_form_tables, write_map


def _refused(text: str):
    with pytest.raises(InputRejected) as caught:
        parse_upload(StoredInput("m.map", content=text.encode()), {"units": {"flow": "kg/s"}})
    (error,) = caught.value.errors
    return error


def _line_of(text: str, cell: str, after: str) -> int:
    lines = text.split("\n")
    start = lines.index(after)
    return next(i for i, line in enumerate(lines[start:], start) if cell in line.split()) + 1


@pytest.mark.parametrize("table, huge", [("Mass Flow", "1e308"), ("Efficiency", "-1e30"), ("Pressure Ratio", "2e12")])
def test_a_value_beyond_1e12_is_refused_naming_its_line(table, huge):
    W, E, P = closed_form_tables()
    text = write_map(W, E, P)
    cell = f"{ {'Mass Flow': W, 'Efficiency': E, 'Pressure Ratio': P}[table][1][3]:.10g}"
    n = _line_of(text, cell, table)
    lines = text.split("\n")
    lines[n - 1] = " ".join(huge if c == cell else c for c in lines[n - 1].split())
    error = _refused("\n".join(lines))
    assert error.loc == ("file", "line", n)
    assert f"line {n}:" in error.msg and table in error.msg and "beyond 1e+12" in error.msg


def test_a_speed_beyond_1e12_is_refused_naming_its_line():
    W, E, P = closed_form_tables()
    text = write_map(W, E, P, speeds=[0.6, 0.7, 1e300, 0.9])
    error = _refused(text)
    assert error.loc == ("file", "line", _line_of(text, "1e+300", "Mass Flow"))


def test_nan_and_infinite_values_stay_missing_points_dropped_with_a_note():
    W, E, P = closed_form_tables()
    W = W.copy()
    W[1][3] = float("inf")
    request = parse_upload(StoredInput("m.map", content=write_map(W, E, P).encode()), {"units": {"flow": "kg/s"}})
    assert any(w.code == "upload_points_dropped" for w in request.upload_warnings)
    assert len(request.positions[1].flow) == len(W[1]) - 1


def test_a_geometry_setting_beyond_1e12_is_refused_naming_its_line():
    W, E, P = closed_form_tables()
    sets = [write_map(w, E, P, head="3    variable geometry compressor").split("\n") for w in (W, 1.1 * W)]
    head, first, second = "\n".join(sets[0][:2]), "\n".join(sets[0][2:]), "\n".join(sets[1][2:])
    error = _refused(f"{head}\nVG angle = 1e308 [deg]\n{first}VG angle = 5 [deg]\n{second}")
    assert error.loc == ("file", "line", 3) and "setting 1e+308" in error.msg


@pytest.mark.parametrize("text", ["\n\n  \n", "\ufeff\r\n\t\r\n"])
def test_a_map_of_blank_lines_is_refused_saying_so_not_taken_for_json(text):
    with pytest.raises(InputRejected) as caught:
        parse_upload(StoredInput("m.map", content=text.encode()), None)
    (error,) = caught.value.errors
    assert error.loc == ("file",) and "only blank lines" in error.msg and "JSON" not in error.msg
