"""An ASCII STL of a tube exported in a decimal-comma locale (`vertex 3,25 0 0`): every facet is skipped, and the
refusal says why, naming the lines and the decimal comma, not only 'not numbers'."""

from __future__ import annotations

import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.tube.upload import parse_upload


def _facet(i: int, comma: bool) -> str:
    a, b = float(i), float(i) + 0.5
    corners = [(a, 0.0, 0.0), (b, 1.25, 0.0), (a, 0.0, 2.5)]
    write = (lambda v: f"{v:.4f}".replace(".", ",")) if comma else (lambda v: f"{v:.4f}")
    lines = [" facet normal 0 0 1", "  outer loop"]
    lines += [f"   vertex {write(x)} {write(y)} {write(z)}" for x, y, z in corners]
    return "\n".join(lines + ["  endloop", " endfacet"])


def _stl(comma: bool) -> bytes:
    return ("solid tube\n" + "\n".join(_facet(i, comma) for i in range(60)) + "\nendsolid tube\n").encode()


def test_a_decimal_comma_stl_is_refused_naming_the_decimal_comma_and_the_line():
    with pytest.raises(InputRejected) as refused:
        parse_upload(StoredInput.from_bytes("tube.stl", _stl(comma=True)), None)
    text = str(refused.value)
    assert "decimal comma" in text
    assert "4" in text  # the first vertex line


def test_the_same_stl_with_decimal_points_reads():
    request = parse_upload(StoredInput.from_bytes("tube.stl", _stl(comma=False)), None)
    assert request is not None
