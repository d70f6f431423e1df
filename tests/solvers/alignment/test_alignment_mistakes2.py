"""A second round of mistakes in PCF files: a bore written as a negative number or zero, a fixed component named
by an identifier two items carry, a block pasted twice, a coordinate no tool writes. Each gets a refusal naming
the field, or a warning naming the lines — not a quietly different network."""

from __future__ import annotations

import pytest

from plantsolve.solvers.alignment.solve import solve
from plantsolve.solvers.alignment.upload import parse_upload
from plantsolve.solvers.alignment.validation import check_input
from plantsolve.solvers.base import InputRejected, StoredInput
from tests.conftest import REPO

LADDER = (REPO / "examples" / "alignment" / "ladder.pcf").read_text()
FIXED = {"fixed_components": ["N0-0"]}


def _solve(text: str, options: dict | None = None):
    request = parse_upload(StoredInput.from_bytes("ladder.pcf", text.encode()), options)
    check_input(request)
    return solve(request).result


def _warnings(result) -> dict:
    return {w.code: w for w in result.report.warnings}


@pytest.mark.parametrize("bore", ["-100.0000", "0.0000", "abc"])
def test_a_bore_that_is_no_positive_number_is_named_with_its_lines(bore):
    text = LADDER.replace(" 100.0000\n", f" {bore}\n")
    lines = [i + 1 for i, line in enumerate(text.splitlines()) if line.split()[:1] in (["END-POINT"], ["BRANCH1-POINT"])]
    result = _solve(text, FIXED)
    # before: read as no bore, 8 items left unconnected and the network split in four, with no word on the bores
    warning = _warnings(result)["pcf_bore_unreadable"]
    assert [p["line"] for p in warning.details["points"]] == lines
    assert f"line {lines[0]} ({bore})" in warning.message
    assert "pcf_bore_unreadable" not in _warnings(_solve(LADDER, FIXED))


def test_a_fixed_component_named_by_an_identifier_two_items_carry_is_refused_naming_both():
    text = LADDER.replace("COMPONENT-IDENTIFIER N0-1", "COMPONENT-IDENTIFIER N0-0")
    lines = [i + 1 for i, line in enumerate(text.splitlines()) if line.strip() == "ELBOW"][:2]
    with pytest.raises(InputRejected) as refused:
        parse_upload(StoredInput.from_bytes("ladder.pcf", text.encode()), FIXED)
    (error,) = refused.value.errors
    assert error.loc == ("options", "fixed_components", 0)
    # before: "unknown component 'N0-0'", which the file plainly holds (twice)
    assert f"identifier of 2 items (lines {lines[0]}, {lines[1]})" in error.msg and "ELBOW-1, ELBOW-2" in error.msg
    # its positional id is accepted and fixes the one meant
    result = _solve(text, {"fixed_components": ["ELBOW-1"]})
    assert result.converged


def test_an_item_pasted_twice_is_named_with_the_one_it_repeats():
    blocks = LADDER.split("\nTEE\n")
    tee = "TEE\n" + blocks[1].split("\n", 1)[0] + "\n" + "\n".join(
        line for line in blocks[1].split("\n")[1:] if line.startswith("    "))
    text = LADDER.rstrip("\n") + "\n" + tee.replace("COMPONENT-IDENTIFIER", "COMPONENT-IDENTIFIER X") + "\n"
    first = LADDER.splitlines().index("TEE") + 1
    last = len(LADDER.splitlines()) + 1
    result = _solve(text, FIXED)
    (pair,) = _warnings(result)["pcf_duplicate_items"].details["items"]
    assert (pair["line"], pair["same_as_line"]) == (last, first)
    assert "pcf_duplicate_items" not in _warnings(_solve(LADDER, FIXED))


def test_an_item_held_for_an_absurd_coordinate_is_named_by_line_in_the_message():
    text = LADDER.replace("1000150.0000 200000.0000", "1e300 200000.0000", 1)
    item = text.splitlines().index("ELBOW") + 1  # the held item's line, its bad point line quoted
    warning = _warnings(_solve(text, FIXED))["pcf_items_held"]
    assert f"line {item}: coordinate beyond 1e+12 in 'END-POINT 1e300 " in warning.message


def test_a_file_whose_units_records_disagree_is_refused_naming_both_lines():
    text = LADDER.replace("UNITS-CO-ORDS MM\n", "UNITS-CO-ORDS MM\nUNITS-CO-ORDS INCH\n")
    first = text.splitlines().index("UNITS-CO-ORDS MM") + 1
    # before: the first record was taken for every coordinate, with no word on the second
    with pytest.raises(InputRejected) as refused:
        parse_upload(StoredInput.from_bytes("ladder.pcf", text.encode()), FIXED)
    assert f"line {first}: MM, line {first + 1}: INCH" in refused.value.errors[0].msg
    # the same unit written twice (and spelt otherwise) is no contradiction
    same = LADDER.replace("UNITS-CO-ORDS MM\n", "UNITS-CO-ORDS MM\nUNITS-CO-ORDS MILLIMETRE\n")
    assert _solve(same, FIXED).converged
