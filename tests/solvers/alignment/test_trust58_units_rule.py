"""A request file's ``units`` is read by the upload form's one rule set (``solvers.upload_form``) in every kind whose
form ``units`` is the file's: tube and alignment read it with wrappers of their own before, so 'yd' was said with
the units' names there and as the bare enum in flowmeter, and 'µm' was an 'unknown unit' in tube and alignment
where flowmeter said it is micrometres, a unit no request is in."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.kinds import load_kinds

EXAMPLES = Path(__file__).resolve().parents[3] / "examples"
KINDS = load_kinds(())
FILES = {"tube": "tube/scan_request.json", "alignment": "alignment/ladder.json", "flowmeter": "flowmeter/meter.json"}


def _refusal(kind: str, units: object, form: dict | None = None) -> tuple[tuple, str]:
    body = json.loads((EXAMPLES / FILES[kind]).read_text()) | {"units": units}
    with pytest.raises(InputRejected) as caught:
        KINDS[kind].parse_upload(StoredInput.from_bytes("request.json", json.dumps(body).encode()), form)
    (error,) = caught.value.errors
    return error.loc, error.msg


@pytest.mark.parametrize("kind", FILES)
def test_a_file_unit_is_refused_in_the_same_words_by_every_kind(kind):
    assert _refusal(kind, "yd") == (("file", "units"), "unknown unit 'yd'; one of mm, cm, m, in, ft (or their names: "
                                                       "millimetres, inches, ...)")
    loc, msg = _refusal(kind, "µm", {"units": "mm"})
    assert loc == ("file", "units") and msg.startswith("'µm' is micrometres, a unit only a file's coordinates")
    assert _refusal(kind, "Mm")[1].startswith("'Mm' reads as the megametre")


@pytest.mark.parametrize("kind", FILES)
def test_a_file_unit_is_read_by_its_names_and_may_be_repeated_never_contradicted(kind):
    body = json.loads((EXAMPLES / FILES[kind]).read_text()) | {"units": " Inches "}
    request = KINDS[kind].parse_upload(StoredInput.from_bytes("r.json", json.dumps(body).encode()), {"units": "IN"})
    assert request.units == "in"
    loc, msg = _refusal(kind, "millimetres", {"units": "in"})
    assert loc == ("options", "units") and "contradicts the file's file.units 'millimetres'" in msg
