"""A part's own drawing from the LDraw library (``0 !LDRAW_ORG Part``) uploaded as a model is refused with a 422
saying so: with primitives (stud.dat) it was answered as 2 unknown parts and dof 0, with lines 2-5 alone as 'places
no part' without saying why."""

from __future__ import annotations

import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.rigidity.upload import parse_upload

PART = """0 Brick  1 x  2
0 Name: 3004.dat
0 Author: James Jessiman
0 !LDRAW_ORG Part UPDATE 2004-03
0 BFC CERTIFY CCW
2 24 -20 0 -10 20 0 -10
3 16 -20 0 -10 20 0 -10 20 24 -10
4 16 -20 24 -10 20 24 -10 20 24 10 -20 24 10
5 24 20 0 10 20 24 10 20 0 -10 -20 0 10
"""
STUDS = "1 16 10 0 0 1 0 0 0 1 0 0 0 1 stud.dat\n1 16 -10 0 0 1 0 0 0 1 0 0 0 1 stud.dat\n"


@pytest.mark.parametrize("text", [PART, PART + STUDS, "0 FILE 3004.dat\n" + PART + STUDS])
def test_a_part_drawing_is_refused_as_no_model(text):
    with pytest.raises(InputRejected) as refused:
        parse_upload(StoredInput.from_bytes("3004.ldr", text.encode()), None)
    (error,) = refused.value.errors
    assert error.loc == ("file",)
    assert "a part's drawing, not a model" in error.msg and "'3004.dat'" in error.msg and "LDRAW_ORG Part" in error.msg

