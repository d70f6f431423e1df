"""An ASCII STL saved with a UTF-8 byte-order mark (Notepad's 'UTF-8 with BOM', a .NET writer's default) is the
room it describes: it was refused as 'not an STL file: it is text'. A binary STL whose header happens to start with
the mark's bytes stays binary."""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np
import pytest

from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.polyhedra.solve import solve
from plantsolve.solvers.polyhedra.upload import parse_upload

BOX = (Path(__file__).parent / "data" / "ascii_box.stl").read_bytes()
MARK = b"\xef\xbb\xbf"


def _solved(content: bytes):
    return solve(parse_upload(StoredInput.from_bytes("room.stl", content), None)).result


@pytest.mark.parametrize("ending", [b"\n", b"\r\n"])
def test_an_ascii_stl_with_a_utf8_mark_is_the_box_it_describes(ending):
    result = _solved(MARK + BOX.replace(b"\n", ending))
    (zone,) = result.zones
    # the pump housing is 2 x 1 x 0.5 m
    assert zone.closed and zone.volume == pytest.approx(1.0) and zone.surface_area == pytest.approx(7.0)
    assert result.report.warnings == []


def test_a_binary_stl_whose_header_starts_with_the_marks_bytes_is_read_as_binary():
    unmarked = _solved(BOX)
    corners = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], float)
    quads = [(0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7)]
    triangles = [(q[0], q[1], q[2]) for q in quads] + [(q[0], q[2], q[3]) for q in quads]
    header = (MARK + b"solid box, written by a tool that marks its headers").ljust(80, b" ")
    body = b"".join(struct.pack("<12fH", 0, 0, 0, *corners[list(t)].ravel(), 0) for t in triangles)
    result = _solved(header + struct.pack("<I", len(triangles)) + body)
    (zone,) = result.zones
    assert zone.closed and zone.volume == pytest.approx(unmarked.zones[0].volume) == pytest.approx(1.0)
