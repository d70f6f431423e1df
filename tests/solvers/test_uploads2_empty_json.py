"""A JSON upload of blank lines only is refused as empty; json's 'Expecting value' at its end read as a cut file
('the JSON ends before its document is complete … the file was cut?'), which sent the user looking for the rest."""

import pytest

from plantsolve.solvers.alignment.upload import parse_upload as alignment_upload
from plantsolve.solvers.base import InputRejected, StoredInput, json_object
from plantsolve.solvers.dedup.upload import parse_upload as dedup_upload
from plantsolve.solvers.flowmeter.upload import parse_upload as flowmeter_upload
from plantsolve.solvers.perfmap.upload import parse_upload as perfmap_upload
from plantsolve.solvers.polyhedra.upload import parse_upload as polyhedra_upload
from plantsolve.solvers.rigidity.upload import parse_upload as rigidity_upload
from plantsolve.solvers.tube.upload import parse_upload as tube_upload

READERS = {"alignment": alignment_upload, "dedup": dedup_upload, "flowmeter": flowmeter_upload,
           "perfmap": perfmap_upload, "polyhedra": polyhedra_upload, "rigidity": rigidity_upload,
           "tube": tube_upload}
BLANK = [b"\n\n  \n", b"\r\n\t\r\n ", "\ufeff\n".encode(), " \n".encode("utf-16")]


@pytest.mark.parametrize("kind", READERS)
@pytest.mark.parametrize("content", BLANK)
def test_a_json_upload_of_blank_lines_is_refused_as_empty_not_as_cut(kind, content):
    with pytest.raises(InputRejected) as caught:
        READERS[kind](StoredInput.from_bytes("request.json", content), None)
    (error,) = caught.value.errors
    assert error.loc == ("file",)
    assert "empty" in error.msg and "cut" not in error.msg and "ends before" not in error.msg


@pytest.mark.parametrize("text", ["{}", " \n[1]\n"])
def test_a_document_after_blank_lines_is_still_read(text):
    assert json_object(text, list_as="points") in ({}, {"points": [1]})


def test_a_cut_document_after_blank_lines_is_still_said_to_be_cut():
    with pytest.raises(InputRejected, match="the file was cut"):
        json_object("\n\n  {\"a\": [1, 2", refuse_cut=True)
