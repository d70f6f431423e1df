"""Two PCF statements a file can leave out and the reader then assumed without a word: an END-POINT's bore (three
numbers: the item connects with the file's typical bore, 10 mm when none has one) and the UNITS-CO-ORDS record
(coordinates read in millimetres: an inch file's gaps said 25.4 times too small). Both are named now; the exports'
own files say neither."""

import re
from pathlib import Path

import pytest

from plantsolve.solvers.alignment.pcf import interpret_pcf

DATA = Path(__file__).parent / "data"
SP3D_INCH = (DATA / "sp3d_inch_tabs.pcf").read_text()
FIXTURES = [*sorted(DATA.glob("*.pcf")), Path(__file__).parents[3] / "examples" / "alignment" / "ladder.pcf"]


def _warnings(text: str) -> dict:
    return {code: (message, details) for code, message, details, level in interpret_pcf(text, {}).notes
            if level == "warning"}


def _without_bores(text: str, count: int = 0) -> str:
    return re.sub(r"(?im)^(\s*(?:end|branch\d)-point\s+\S+\s+\S+\s+\S+)\s+\S+.*$", r"\1", text, count=count)


def test_end_points_written_without_a_bore_are_named_by_line():
    text = _without_bores(SP3D_INCH, count=1)
    message, details = _warnings(text)["pcf_bore_missing"]
    (point,) = details["points"]
    assert text.splitlines()[point["line"] - 1].split() == ["end-point", "-100", "50", "12"]
    assert point["id"] == "F4WN150" and f"line {point['line']}" in message and "typical bore" in message


def test_a_file_with_no_bore_at_all_says_how_far_its_connections_reach():
    text = _without_bores(SP3D_INCH)
    message, details = _warnings(text)["pcf_bore_missing"]
    assert len(details["points"]) == details["end_points"] and "10 mm" in message


def test_a_file_without_units_co_ords_says_it_was_read_in_millimetres():
    text = re.sub(r"(?im)^UNITS-.*\n", "", SP3D_INCH)
    interpretation = interpret_pcf(text, {})
    message, details = _warnings(text)["pcf_units_assumed"]
    assert interpretation.body["units"] == "mm" and details["assumed"] == "MM" and "UNITS-CO-ORDS" in message


@pytest.mark.parametrize("path", FIXTURES, ids=lambda p: p.name)
def test_exports_and_fixtures_raise_neither(path):
    warnings = _warnings(path.read_bytes().decode("utf-8", errors="replace"))
    assert "pcf_bore_missing" not in warnings and "pcf_units_assumed" not in warnings


LADDER = FIXTURES[-1].read_text()


@pytest.mark.parametrize("cut", ["PI", "FLA", "ELB"])
def test_a_file_cut_as_an_item_keyword_began_is_said_to_be_cut(cut):
    whole = LADDER.splitlines()
    k = next(i for i, line in enumerate(whole) if i > len(whole) // 2 and line == "PIPE")
    text = "\n".join(whole[:k]) + "\n" + cut
    message, details = _warnings(text)["truncated_file"]
    assert details["line"] == k + 1 and details["keyword"] == cut and f"line {k + 1}" in message


def test_an_unknown_word_with_its_line_ending_is_no_cut():
    whole = LADDER.splitlines()
    k = next(i for i, line in enumerate(whole) if i > len(whole) // 2 and line == "PIPE")
    assert "truncated_file" not in _warnings("\n".join(whole[:k]) + "\nPI\n")
