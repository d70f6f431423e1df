"""A model of another kind uploaded under a text scan's extension is refused naming what it holds, not read as
numbers (an LDraw part line's colour and position would otherwise pass as x, y, z)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.other_kinds import file_holds
from plantsolve.solvers.tube.upload import parse_upload

EXAMPLES = Path(__file__).resolve().parents[3] / "examples"
HELIX_LDRAW = "0 FILE model.ldr\n0 Name: model.ldr\n" + "".join(
    f"1 4 {10 * math.cos(i / 3):.2f} {10 * math.sin(i / 3):.2f} {i * 0.5:.2f} 1 0 0 0 1 0 0 0 1 3001.dat\n"
    for i in range(300))


@pytest.mark.parametrize("content,holds", [
    (HELIX_LDRAW.encode(), "an LDraw model"),
    ((EXAMPLES / "rigidity" / "hinged_wall.ldr").read_bytes(), "an LDraw model"),
    ((EXAMPLES / "polyhedra" / "two_offices.idf").read_bytes(), "an EnergyPlus IDF"),
    ((EXAMPLES / "dedup" / "zoo_ifc2x3.ifc").read_bytes(), "an IFC model"),
])
@pytest.mark.parametrize("name", ["scan.xyz", "scan.csv", "scan.txt"])
def test_a_model_of_another_kind_is_refused_naming_it(tmp_path, content, holds, name):
    path = tmp_path / name
    path.write_bytes(content)
    with pytest.raises(InputRejected) as refused:
        parse_upload(StoredInput.from_path(path), None)
    error = refused.value.errors[0]
    assert error.loc == ("file",) and holds in error.msg and "not x, y, z samples" in error.msg


@pytest.mark.parametrize("rows", [
    "1 4 0 1 0 0 0 1 0 0 0 1 0 0 0\n",  # fifteen numbers with no file name: not a part line
    "1 2 3\n",
])
def test_numbers_alone_are_no_ldraw_model(rows):
    assert file_holds((rows * 200).encode()) is None


def test_a_point_list_with_a_header_is_still_read(tmp_path):
    t = np.linspace(0, 6, 400)
    path = tmp_path / "scan.csv"
    path.write_text("x,y,z\n" + "".join(f"{10 * math.cos(a)},{10 * math.sin(a)},{5 * a}\n" for a in t))
    request = parse_upload(StoredInput.from_path(path), None)
    assert len(request.points) == 400
