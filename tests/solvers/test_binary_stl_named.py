"""A binary STL sent where another format is read is refused naming it: before, alignment said 'text beginning
'\\x00\\x00…'', dedup 'not an IFC file' without a word of what it held, and the text readers 'a binary file'."""

from __future__ import annotations

import pytest
import trimesh

from plantsolve.solvers.base import InputRejected, StoredInput, decode_text
from plantsolve.solvers.other_kinds import file_holds

STL = trimesh.creation.box(extents=(10.0, 20.0, 30.0)).export(file_type="stl")


def test_a_binary_stl_is_recognised_from_its_start_and_text_or_noise_is_not():
    assert file_holds(STL[:65536]) == "a binary STL mesh"
    assert file_holds(b"x,y,z\n1,2,3\n4,5,6\n") != "a binary STL mesh"
    assert file_holds(bytes(200)) != "a binary STL mesh"  # a count of 0: no triangle to judge


@pytest.mark.parametrize("kind, name", [("alignment", "line.pcf"), ("dedup", "model.ifc")])
def test_a_binary_stl_sent_to_another_kind_is_refused_naming_it(kind, name):
    from plantsolve.solvers.kinds import KINDS
    with pytest.raises(InputRejected) as refused:
        KINDS[kind].parse_upload(StoredInput.from_bytes(name, STL), None)
    assert "binary STL mesh" in refused.value.errors[0].msg


def test_the_text_decoder_names_a_binary_stl():
    with pytest.raises(InputRejected, match="a binary STL mesh"):
        decode_text(STL, "rig table")
