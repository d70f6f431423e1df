"""A sub-model headed '0 !LDRAW_ORG Part' (a header copied from a part file) that places several catalogue parts is
expanded as a sub-model: read as one part, its hinge was frozen and the model's degrees of freedom undercounted."""

from __future__ import annotations

import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.rigidity.solve import solve
from plantsolve.solvers.rigidity.upload import parse_upload
from tests.conftest import REPO

WALL = [line for line in (REPO / "examples" / "rigidity" / "hinged_wall.ldr").read_text().splitlines()
        if line.startswith("1 ")]


def solved(header: str):
    text = "\n".join(["0 FILE main.ldr", "0 !LDRAW_ORG Unofficial_Model",
                      "1 4 0 0 0 1 0 0 0 1 0 0 0 1 wall.ldr", "0 FILE wall.ldr", header, *WALL]) + "\n"
    return solve(parse_upload(StoredInput.from_bytes("wall.mpd", text.encode()), None)).result


def test_a_sub_model_headed_part_keeps_its_hinges_and_is_warned_about():
    plain = solved("0 !LDRAW_ORG Unofficial_Model")
    for header in ("0 !LDRAW_ORG Unofficial_Part", "0 !LDRAW_ORG Part UPDATE 2020-01"):
        result = solved(header)
        assert (result.dof, len(result.clusters)) == (plain.dof, len(plain.clusters)) == (4, 5)
        warning = next(w for w in result.report.warnings if w.code == "part_header_on_submodel")
        assert warning.details["submodels"] == ["wall.ldr"]
        assert "'wall.ldr' (9 parts: 3001, 3001, 3937, 3938 …)" in warning.message


def test_an_unofficial_shortcut_of_a_hinge_s_two_halves_keeps_the_hinge():
    text = "\n".join(["0 FILE main.ldr", "1 4 0 0 0 1 0 0 0 1 0 0 0 1 3001.dat",
                      "1 15 -20 -24 10 1 0 0 0 1 0 0 0 1 hinge.dat", "0 FILE hinge.dat",
                      "0 !LDRAW_ORG Unofficial_Shortcut", "1 15 0 0 0 1 0 0 0 1 0 0 0 1 3937.dat",
                      "1 15 0 0 0 1 0 0 0 1 0 0 0 1 3938.dat"]) + "\n"
    result = solve(parse_upload(StoredInput.from_bytes("hinge.mpd", text.encode()), None)).result
    assert (result.dof, len(result.clusters)) == (1, 2)  # the top half turns about the hinge (was 0: one body)
    assert [w.code for w in result.report.warnings] == ["part_header_on_submodel"]


def test_ldraw_lines_with_decimal_commas_are_named_so_not_called_a_table():
    text = "1 4 0,0 0,0 0,0 1,0 0,0 0,0 0,0 1,0 0,0 0,0 0,0 1,0 3001.dat\n" \
           "1 4 0,0 -24,0 0,0 1,0 0,0 0,0 0,0 1,0 0,0 0,0 0,0 1,0 3001.dat\n"
    with pytest.raises(InputRejected) as caught:
        parse_upload(StoredInput.from_bytes("model.ldr", text.encode()), None)
    (error,) = caught.value.errors
    assert error.loc == ("file",)
    assert error.msg == ("the file places no part (no usable type-1 line) — line 1: position or rotation is not a "
                         "number ('0,0': a decimal comma; LDraw numbers take a decimal point); line 2: position or "
                         "rotation is not a number ('0,0': a decimal comma; LDraw numbers take a decimal point)")
