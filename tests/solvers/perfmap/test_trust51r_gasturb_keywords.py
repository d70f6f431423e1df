"""A GasTurb map whose table keyword is misspelt (trust51r probe): the table under 'Efficency' or 'Massflow' was read
as one a compressor map does not need, and the refusal said only 'no Efficiency table', naming no line, while the
user saw the table in the file. The refusal names the line and the keyword it misspells; a heading that is no
misspelling ('Corr. Flow') is refused as before."""

from __future__ import annotations

import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.perfmap.upload import parse_upload
from tests.solvers.perfmap.conftest import DATA

COMPMAP = (DATA / "gasturb" / "compmap.map").read_text()


def _refusal(text: str):
    with pytest.raises(InputRejected) as refused:
        parse_upload(StoredInput.from_bytes("compmap.map", text.encode()), {})
    (error,) = refused.value.errors
    return error


@pytest.mark.parametrize("keyword, written, line", [
    ("Mass Flow", "Massflow", 3), ("Mass Flow", "Mas Flow [kg/s]", 3), ("Efficiency", "Efficency", 20),
    ("Pressure Ratio", "PressureRatio", 37), ("Pressure Ratio", "Press. Ratio", 37),
])
def test_a_misspelt_keyword_is_named_by_its_line(keyword, written, line):
    assert COMPMAP.splitlines()[line - 1] == keyword
    error = _refusal(COMPMAP.replace(keyword, written, 1))
    assert error.loc == ("file", "line", line)
    assert f"line {line} heads a table {written!r}: the {keyword} keyword misspelt?" in error.msg


@pytest.mark.parametrize("keyword, written", [("Mass Flow", "Corr. Flow"), ("Efficiency", "Eff")])
def test_a_heading_that_is_no_misspelling_is_refused_as_a_missing_table(keyword, written):
    error = _refusal(COMPMAP.replace(keyword, written, 1))
    assert error.loc == ("file", keyword) and "misspelt" not in error.msg


def test_the_map_with_its_keywords_right_still_reads():
    request = parse_upload(StoredInput.from_bytes("compmap.map", COMPMAP.encode()), {})
    assert len(request.positions) == 12
