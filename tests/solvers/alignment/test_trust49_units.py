"""An alignment JSON file's unit by any of its spellings ('MM', 'Millimeters') is read; 'Mm' is refused naming both
of its readings. Before, each was refused as not one of mm, cm, m, in, ft."""

from __future__ import annotations

import json

import pytest

from plantsolve.solvers.alignment.upload import parse_upload as alignment_upload
from plantsolve.solvers.base import InputRejected, StoredInput
from tests.conftest import REPO

LADDER = json.loads((REPO / "examples" / "alignment" / "ladder.json").read_text())


@pytest.mark.parametrize("word, unit", [("MM", "mm"), ("Millimeters", "mm"), ("METRES", "m")])
def test_an_alignment_json_file_reads_its_unit_in_any_spelling(word, unit):
    body = {**LADDER, "units": word}
    request = alignment_upload(StoredInput.from_bytes("ladder.json", json.dumps(body).encode()), None)
    assert request.units == unit
    same = alignment_upload(StoredInput.from_bytes("ladder.json", json.dumps({**LADDER, "units": unit}).encode()), None)
    assert request.model_dump() == same.model_dump()


def test_an_alignment_json_file_in_mm_with_a_capital_m_is_refused_naming_both_readings():
    body = json.dumps({**LADDER, "units": "Mm"}).encode()
    with pytest.raises(InputRejected) as caught:
        alignment_upload(StoredInput.from_bytes("ladder.json", body), None)
    (error,) = caught.value.errors
    loc, msg = error.loc, error.msg
    assert loc == ("file", "units") and "megametre" in msg and "millimetres" in msg
