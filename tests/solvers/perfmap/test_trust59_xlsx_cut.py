"""A workbook cut inside the end record of its zip directory (the last 22 bytes: an upload or copy that stopped a
few bytes short) is refused as cut short, as one cut before its directory is; before, the record's signature left
in the file made it a workbook that 'is not readable (BadZipFile)', with no word of the cut."""

from __future__ import annotations

import io

import openpyxl
import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.perfmap.upload import parse_upload

ROWS = [["speed [-]", "flow [kg/s]", "PR [-]", "efficiency [-]"]] + [
    [n, w, 1.0 + 0.8 * n * n - 0.002 * w * w * (1 - n), 0.8] for n in (0.8, 0.9, 1.0) for w in (10.0, 12.0, 14.0)]


def _workbook() -> bytes:
    book = openpyxl.Workbook()
    for row in ROWS:
        book.active.append(row)
    out = io.BytesIO()
    book.save(out)
    return out.getvalue()


@pytest.mark.parametrize("short", [1, 10, 21, 400])
def test_a_workbook_cut_short_says_so(short):
    data = _workbook()
    with pytest.raises(InputRejected) as refused:
        parse_upload(StoredInput.from_bytes("rig.xlsx", data[:-short]), {"map": False})
    (error,) = refused.value.errors
    assert error.loc == ("file",)
    assert f"it is cut short, ending after {len(data) - short:,} bytes" in error.msg


def test_the_whole_workbook_reads():
    request = parse_upload(StoredInput.from_bytes("rig.xlsx", _workbook()), {"map": False})
    assert sorted(p.setting[0] for p in request.positions) == [0.8, 0.9, 1.0]
