"""An .ifczip whose .ifc is empty is refused saying the model is empty; it was said to be UTF-16 text (an empty
start passed the test for a NUL as every second byte)."""

from __future__ import annotations

import io
import zipfile

import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.dedup.ifcio import check_header
from plantsolve.solvers.dedup.source import IfcSource
from plantsolve.solvers.dedup.upload import parse_upload


def _zipped(text: bytes) -> bytes:
    out = io.BytesIO()
    with zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as archive:
        archive.writestr("model.ifc", text)
    return out.getvalue()


@pytest.mark.parametrize("member", [b"", b"\r\n  \n", b"\xef\xbb\xbf"])
def test_an_ifczip_holding_an_empty_ifc_is_refused_as_empty(member):
    upload = StoredInput.from_bytes("model.ifczip", _zipped(member))
    with pytest.raises(InputRejected) as caught:
        IfcSource(parse_upload(upload, None), upload).header()
    (error,) = caught.value.errors
    assert error.loc == ("file",) and "empty" in error.msg and "UTF-16" not in error.msg


def test_utf16_text_is_still_told():
    text = "ISO-10303-21;\nHEADER;\n".encode("utf-16-le")
    with pytest.raises(InputRejected, match="UTF-16"):
        check_header(text, b"")
