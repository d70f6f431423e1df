"""An ASCII STL or OBJ written with decimal commas ('vertex 3,25 0 0', a decimal-comma locale's export): the STL was
refused as 'unreadable STL: ValueError: string or file could not be read to its end…', no line named; the OBJ named
the line but said only 'could not convert string to float'. Both now name the line and say decimal comma."""

from __future__ import annotations

import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.polyhedra import SPEC
from plantsolve.solvers.polyhedra.upload import parse_obj

CORNERS = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1)]
TRIANGLES = [(0, 2, 1), (0, 3, 2), (4, 5, 6), (4, 6, 7), (0, 1, 5), (0, 5, 4), (1, 2, 6), (1, 6, 5), (2, 3, 7),
             (2, 7, 6), (3, 0, 4), (3, 4, 7)]


def ascii_stl(name: str = "room", comma_from: int | None = None, normal: str = "0 0 0") -> str:
    """A 3.25 m cube room; the corners from facet ``comma_from`` on written with decimal commas."""
    out = [f"solid {name}"]
    for k, t in enumerate(TRIANGLES):
        out += [f"  facet normal {normal}", "    outer loop"]
        for i in t:
            line = "      vertex " + " ".join(f"{c * 3.25:.4f}" for c in CORNERS[i])
            out.append(line.replace(".", ",") if comma_from is not None and k >= comma_from else line)
        out += ["    endloop", "  endfacet"]
    return "\n".join(out + [f"endsolid {name}"]) + "\n"


def obj(commas: bool = False) -> str:
    lines = ["v " + " ".join(f"{c * 3.25:.4f}" for c in p) for p in CORNERS]
    if commas:
        lines = [line.replace(".", ",") for line in lines]
    return "\n".join(["# a room", *lines, *("f " + " ".join(str(i + 1) for i in t) for t in TRIANGLES)]) + "\n"


def parsed(name: str, text: str):
    return SPEC.parse_upload(StoredInput.from_bytes(name, text.encode()), None)


def refusal(name: str, text: str):
    with pytest.raises(InputRejected) as refused:
        parsed(name, text)
    (error,) = refused.value.errors
    return error


def test_an_ascii_stl_with_decimal_commas_is_refused_naming_the_line_and_the_comma():
    error = refusal("room.stl", ascii_stl(comma_from=0))
    assert error.loc == ("file", "line", 4)
    assert error.msg.startswith("line 4: 'vertex 0,0000 0,0000 0,0000': '0,0000' is a decimal comma")


def test_decimal_commas_in_a_later_facet_or_a_normal_are_named_where_they_stand():
    assert refusal("room.stl", ascii_stl(comma_from=5)).loc == ("file", "line", 5 * 7 + 4)
    error = refusal("room.stl", ascii_stl(normal="0,0 0,0 1,0"))
    assert error.loc == ("file", "line", 2) and "'0,0' is a decimal comma" in error.msg


def test_an_obj_with_a_decimal_comma_names_the_line_and_the_comma():
    error = refusal("room.obj", obj(commas=True))
    assert error.loc == ("file", "line", 2)
    assert "line 2: not a vertex: '0,0000' is a decimal comma; OBJ numbers take a decimal point" in error.msg


def test_an_obj_vertex_with_a_decimal_comma_among_good_ones_is_skipped_saying_so():
    text = obj().replace("v 3.2500 3.2500 3.2500", "v 3,2500 3,2500 3,2500")
    (skip,) = [s for s in parse_obj(text)["source"]["skipped"] if s["object"] == "v"]
    assert skip == {"line": 8, "object": "v",
                    "reason": "not a vertex: '3,2500' is a decimal comma; OBJ numbers take a decimal point"}


def test_files_with_decimal_points_still_read_and_a_comma_in_a_solid_name_is_no_decimal_comma():
    for name, text in (("room.stl", ascii_stl()), ("room.stl", ascii_stl(name="room 1, level 2")), ("room.obj", obj())):
        request = parsed(name, text)
        assert request is not None


def test_an_ascii_stl_vertex_of_other_text_is_named_by_its_line():
    text = ascii_stl().replace("vertex 3.2500 3.2500 3.2500", "vertex 3.2500 3.2500 n/a", 1)
    line = text[:text.index("n/a")].count("\n") + 1
    error = refusal("room.stl", text)
    assert error.loc == ("file", "line", line) and error.msg == f"line {line}: 'vertex 3.2500 3.2500 n/a': not three numbers"
