"""A GasTurb map with a value lost or added inside a speed's record: every later record is shifted, and the reading
fails lines later at a line that is as it should be (the next speed's first line read as values, or one row too
many at the table's end). The refusal names the line that breaks the layout the table's key announces."""

from __future__ import annotations

from pathlib import Path

import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.perfmap.upload import parse_upload

GASTURB = Path(__file__).parent / "data" / "gasturb"


def _refusal(text: str) -> tuple[tuple, str]:
    with pytest.raises(InputRejected) as exc:
        parse_upload(StoredInput.from_bytes("fan.map", text.encode()), {"map": False})
    error = exc.value.errors[0]
    return error.loc, error.msg


def _changed(name: str, line: int, change) -> str:
    lines = (GASTURB / name).read_text().split("\n")
    lines[line - 1] = change(lines[line - 1])
    return "\n".join(lines)


@pytest.mark.parametrize("change, word, later", [
    (lambda line: line.rsplit(None, 1)[0], "lost", 16),  # its next speed's first line read as values
    (lambda line: line + "     16.70000", "added", 47),  # one row too many at the table's end
])
def test_a_value_lost_or_added_in_a_wrapped_record_is_named_on_its_line(change, word, later):
    # bigfand.map wraps its records at five values a line; line 13 is the second line of speed 0.39's Mass Flow row
    text = _changed("bigfand.map", 13, change)
    loc, msg = _refusal(text)
    assert loc == ("file", "line", 13)
    assert f"a value {word} there?" in msg and "Mass Flow table's layout puts 5" in msg
    assert f"line {later}:" in msg  # where reading on as written fails, still said


def test_a_value_lost_in_a_one_record_a_line_map_is_named_on_its_line():
    # compmap.map writes each record on one line of ten values; line 6 is speed 0.50's Mass Flow row
    loc, msg = _refusal(_changed("compmap.map", 6, lambda line: line.rsplit(None, 1)[0]))
    assert loc == ("file", "line", 6)
    assert "9 value(s) where the Mass Flow table's layout puts 10" in msg


def test_a_map_cut_inside_a_table_is_still_a_cut_file_not_a_layout_break():
    text = (GASTURB / "bigfand.map").read_text()
    cut = text[:text.index("Efficiency")] + "Efficiency\n" + text[text.index("Efficiency") + 11:][:200]
    _, msg = _refusal(cut.rsplit("\n", 1)[0] + "\n")
    assert "layout puts" not in msg
