"""A fifth round of mistakes with dedup's files: an .ifczip made by macOS's Finder ('Compress'), whose archive holds
the model and its AppleDouble twin '__MACOSX/._model.ifc', was refused as holding two .ifc files."""

from __future__ import annotations

import io
import zipfile

import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.dedup import SPEC
from plantsolve.solvers.dedup.solve import solve
from plantsolve.solvers.dedup.upload import parse_upload
from tests.conftest import REPO

TUNNEL = (REPO / "examples" / "dedup" / "tunnel_3rings.ifc").read_bytes()
ZOO = (REPO / "examples" / "dedup" / "zoo_ifc2x3.ifc").read_bytes()
APPLE_DOUBLE = b"\x00\x05\x16\x07\x00\x02\x00\x00Mac OS X        " + bytes(64)


def _zipped(*members: tuple[str, bytes]) -> bytes:
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", zipfile.ZIP_DEFLATED) as archive:
        for name, data in members:
            archive.writestr(name, data)
    return buffer.getvalue()


def _input(name: str, content: bytes):
    source = StoredInput.from_bytes(name, content)
    value = SPEC.input_of(parse_upload(source, {}), source)
    SPEC.check_input(value)
    return value


def test_a_finder_archive_of_one_model_is_that_model():
    mac = _input("tunnel.ifczip", _zipped(("tunnel.ifc", TUNNEL), ("__MACOSX/._tunnel.ifc", APPLE_DOUBLE)))
    plain = _input("tunnel.ifc", TUNNEL)
    ours, theirs = solve(mac).result, solve(plain).result
    assert [c.members for c in ours.classes] == [c.members for c in theirs.classes]
    assert len(ours.classes) == 8 and ours.verification.max_deviation == theirs.verification.max_deviation


@pytest.mark.parametrize("members, named", [
    ((("a.ifc", TUNNEL), ("b.ifc", ZOO)), "('a.ifc', 'b.ifc')"),  # two models: which one is meant is not known
    ((("models/a.ifc", TUNNEL), ("models/._a.ifc", APPLE_DOUBLE), ("b.IFC", ZOO)), "('models/a.ifc', 'b.IFC')"),
])
def test_an_archive_of_two_models_is_refused_naming_them(members, named):
    with pytest.raises(InputRejected) as refused:
        _input("models.ifczip", _zipped(*members))
    (error,) = refused.value.errors
    assert error.loc == ("file",) and "holds 2" in error.msg and named in error.msg
