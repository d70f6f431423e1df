"""JSON uploads cut short: the kinds whose request is one JSON document say the file was cut, where it stops;
a document that is wrong before its end stays invalid JSON."""

import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.dedup.upload import parse_upload as dedup_upload
from plantsolve.solvers.flowmeter.upload import parse_upload as flowmeter_upload
from plantsolve.solvers.perfmap.upload import parse_upload as perfmap_upload

READERS = {"flowmeter": flowmeter_upload, "dedup": dedup_upload, "perfmap": perfmap_upload}


@pytest.mark.parametrize("kind", READERS)
@pytest.mark.parametrize("cut", [b'{"options": {"a": 1},\n  "b": [1, 2', b'{"options": {"name": "pump A'])
def test_a_cut_document_is_refused_as_cut_naming_where_it_stops(kind, cut):
    with pytest.raises(InputRejected) as e:
        READERS[kind](StoredInput.from_bytes("request.json", cut), None)
    (error,) = e.value.errors
    assert error.loc == ("file",)
    assert "ends before its document is complete" in error.msg and "the file was cut?" in error.msg
    last_line = cut.count(b"\n") + 1
    assert f"line {last_line}," in error.msg


@pytest.mark.parametrize("kind", READERS)
def test_a_document_wrong_before_its_end_is_invalid_json(kind):
    with pytest.raises(InputRejected, match="invalid JSON") as e:
        READERS[kind](StoredInput.from_bytes("request.json", b'{"options": {"a": 1,, "b": 2}}'), None)
    assert "ends before" not in e.value.errors[0].msg
