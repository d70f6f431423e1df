"""A rig table whose speed column holds each row's measured speed (9497, 9503, …) instead of the speed line's set
value: every row is a setting of its own. It is refused once, naming the column and what to do (before: one 'needs at
least 3 measured points' per row, no word of why); a table with one short speed line is still refused at that line."""

from __future__ import annotations

import io

import openpyxl
import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.perfmap.upload import parse_upload

SET_SPEEDS = (8000, 9000, 10000)
JITTER = (-3, 5, -7, 2)  # a measured speed scatters a few rpm about its set value


def _rows(measured: bool, igv: bool = False) -> list[list]:
    rows = [(["IGV [deg]"] if igv else []) + ["speed [rpm]", "flow [kg/s]", "PR [-]", "efficiency [-]"]]
    for k, n in enumerate(SET_SPEEDS):
        for j, w in enumerate((10.0, 11.0, 12.0, 13.0)):
            speed = n + JITTER[j] + k if measured else n
            rows.append(([-5.0] if igv else []) + [speed, w, round(1 + 0.5 * n / 1e4 - 0.01 * w, 4), 0.8])
    return rows


def _csv(rows: list[list]) -> StoredInput:
    return StoredInput.from_bytes("rig.csv", ("\n".join(",".join(map(str, r)) for r in rows) + "\n").encode())


def _xlsx(rows: list[list]) -> StoredInput:
    book = openpyxl.Workbook()
    for row in rows:
        book.active.append(row)
    out = io.BytesIO()
    book.save(out)
    return StoredInput.from_bytes("rig.xlsx", out.getvalue())


def _refusal(source: StoredInput):
    with pytest.raises(InputRejected) as refused:
        parse_upload(source, {"map": False})
    return refused.value.errors


@pytest.mark.parametrize("form", [_csv, _xlsx])
def test_measured_speeds_on_every_row_are_refused_once_naming_the_column(form):
    (error,) = _refusal(form(_rows(measured=True)))
    assert error.loc == ("file", "header")
    assert error.msg.startswith("column 'speed [rpm]': 12 of the 12 rows each hold a setting of their own "
                                "(7997, 8005, 7993, …)")
    assert "Round them" in error.msg and "'ignore'" in error.msg


def test_the_varying_column_is_named_not_the_vane_setting_beside_it():
    (error,) = _refusal(_csv(_rows(measured=True, igv=True)))
    assert error.msg.startswith("column 'speed [rpm]': ") and "IGV" not in error.msg


def test_the_set_speeds_read_as_three_speed_lines():
    request = parse_upload(_csv(_rows(measured=False)), {"map": False})
    assert [p.setting[0] for p in request.positions] == list(SET_SPEEDS)


def test_one_short_speed_line_is_still_refused_at_its_row():
    rows = _rows(measured=False) + [[11000, 12.0, 1.4, 0.8]]  # a speed line of one point, the others whole
    errors = _refusal(_csv(rows))
    assert [e.loc[:3] for e in errors] == [("file", "row", 14)]
    assert "needs at least 3 measured points" in errors[0].msg
