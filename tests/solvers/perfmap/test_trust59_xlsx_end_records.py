"""The cut-workbook check against the zip end records valid workbooks have: a zip comment after the directory's end
record, and the zip64 end record and locator before it (Python's zipfile reads both). A whole such workbook reads; one
a few bytes short is refused as cut; a whole zip that is no workbook is not said to be cut."""

from __future__ import annotations

import io
import struct
import zipfile

import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.perfmap.upload import parse_upload
from tests.solvers.perfmap.test_trust59_xlsx_cut import _workbook

END = struct.Struct("<4s4H2LH")  # the end of central directory record, without its comment


def _commented(data: bytes, comment: bytes = b"written by the rig's logger, v2.1") -> bytes:
    out = io.BytesIO(data)
    with zipfile.ZipFile(out, "a") as archive:
        archive.comment = comment
    return out.getvalue()


def _zip64(data: bytes) -> bytes:
    """``data`` with a zip64 end record and its locator before the end record, which then defers to them (as a
    writer does past 65,535 entries or 4 GiB)."""
    end = data.rfind(b"PK\x05\x06")
    _, _, _, on_disk, entries, size, offset, comment = END.unpack(data[end:end + END.size])
    record = struct.pack("<4sQ2H2L4Q", b"PK\x06\x06", 44, 45, 45, 0, 0, on_disk, entries, size, offset)
    locator = struct.pack("<4sLQL", b"PK\x06\x07", 0, end, 1)
    deferred = END.pack(b"PK\x05\x06", 0, 0, 0xFFFF, 0xFFFF, 0xFFFFFFFF, 0xFFFFFFFF, comment)
    return data[:end] + record + locator + deferred + data[end + END.size:]


def _read(data: bytes):
    return parse_upload(StoredInput.from_bytes("rig.xlsx", data), {"map": False})


@pytest.mark.parametrize("form", [_commented, _zip64, lambda d: _zip64(_commented(d))])
def test_a_whole_workbook_with_a_comment_or_zip64_records_reads(form):
    data = form(_workbook())
    assert zipfile.ZipFile(io.BytesIO(data)).testzip() is None
    assert sorted(p.setting[0] for p in _read(data).positions) == [0.8, 0.9, 1.0]


@pytest.mark.parametrize("short", [5, 21, 40])
def test_a_zip64_workbook_cut_in_its_end_records_says_so(short):
    data = _zip64(_workbook())
    with pytest.raises(InputRejected) as refused:
        _read(data[:-short])
    assert f"it is cut short, ending after {len(data) - short:,} bytes" in refused.value.errors[0].msg


@pytest.mark.parametrize("form", [_commented, _zip64])
def test_a_whole_zip_that_is_no_workbook_is_not_called_cut(form):
    out = io.BytesIO()
    with zipfile.ZipFile(out, "w") as archive:
        archive.writestr("notes.txt", "speed lines")
    with pytest.raises(InputRejected) as refused:
        _read(form(out.getvalue()))
    assert "cut short" not in refused.value.errors[0].msg
