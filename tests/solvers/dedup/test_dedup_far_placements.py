"""A product placed absurdly far (a placement's origin written 1e300: a unit or exponent slip) is left unchanged and
named, not shared with its congruent neighbours nor passed without a word; the optimized file keeps it as written."""

from __future__ import annotations

import re
from pathlib import Path

import ifcopenshell

from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.dedup import SPEC

TUNNEL = (Path(__file__).parents[3] / "examples" / "dedup" / "tunnel_3rings.ifc").read_bytes()


def _solved(content: bytes):
    stored = StoredInput.from_bytes("tunnel.ifc", content)
    return SPEC.solve(SPEC.input_of(SPEC.parse_upload(stored, None), stored), lambda *a, **k: None)


def test_a_product_placed_at_1e300_is_left_unchanged_and_named():
    axes = re.findall(rb"#\d+=IFCLOCALPLACEMENT\(#\d+,#(\d+)\);", TUNNEL)  # placements relative to another
    axis = axes[len(axes) // 2]
    origin = re.search(rb"#%s=IFCAXIS2PLACEMENT3D\(#(\d+)" % axis, TUNNEL).group(1)
    far = re.sub(rb"(#%s=IFCCARTESIANPOINT\(\()[^)]*(\)\))" % origin, rb"\g<1>1.E300,0.,0.\g<2>", TUNNEL)
    assert far != TUNNEL
    whole, damaged = _solved(TUNNEL), _solved(far)
    (left,) = [w for w in damaged.result.report.warnings if w.code == "left_unchanged"]
    reason = left.details["products"][0]["reason"]
    assert left.details["count"] == 1 and reason.startswith("geometry could not be processed: #")
    assert "IfcCartesianPoint: coordinate 1e+300 is not a finite number" in reason  # the placement's point, named
    assert damaged.result.products_shared == whole.result.products_shared - 1
    written = ifcopenshell.file.from_string(damaged.files["optimized.ifc"].decode())
    moved = written.by_guid(left.details["products"][0]["global_id"])
    assert moved.ObjectPlacement.RelativePlacement.Location.Coordinates[0] == 1e300
