"""A product placed far away is named, relative to the model's own extent: left out of sharing because where it lies
the doubles are too far apart to match it within the tolerance (placement_beyond_tolerance, with its placement's
magnitude and the product it looks like), and lying far from the rest (placement_outlier), shared or not. A
georeferenced model, every product far from the origin, is neither refused nor warned about."""

from __future__ import annotations

import re
from pathlib import Path

from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.dedup import SPEC

EXAMPLES = Path(__file__).parents[3] / "examples" / "dedup"
TUNNEL = (EXAMPLES / "tunnel_3rings.ifc").read_bytes()
PLACEMENT_CODES = {"placement_beyond_tolerance", "placement_outlier"}


def _solved(content: bytes, name: str = "tunnel.ifc"):
    stored = StoredInput.from_bytes(name, content)
    return SPEC.solve(SPEC.input_of(SPEC.parse_upload(stored, None), stored), lambda *a, **k: None).result


def _moved(x: str) -> tuple[bytes, str]:
    """The tunnel with one segment's own placement origin at (x, 0, 0), and that segment's GlobalId."""
    axes = re.findall(rb"#\d+=IFCLOCALPLACEMENT\(#\d+,#(\d+)\);", TUNNEL)
    axis = axes[len(axes) // 2]
    placement = re.search(rb"#(\d+)=IFCLOCALPLACEMENT\(#\d+,#%s\);" % axis, TUNNEL).group(1)
    product = re.search(rb"IFCBUILDINGELEMENTPROXY\('([^']+)',[^;]*,#%s,#\d+" % placement, TUNNEL).group(1).decode()
    origin = re.search(rb"#%s=IFCAXIS2PLACEMENT3D\(#(\d+)" % axis, TUNNEL).group(1)
    moved = re.sub(rb"(#%s=IFCCARTESIANPOINT\(\()[^)]*(\)\))" % origin, rb"\g<1>" + x.encode() + rb",0.,0.\g<2>",
                   TUNNEL)
    assert moved != TUNNEL
    return moved, product


def _warning(result, code):
    return next((w for w in result.report.warnings if w.code == code), None)


def test_a_product_left_out_of_sharing_at_2e11_is_named_with_its_placement():
    clean = _solved(TUNNEL)
    content, moved = _moved("2.E11")
    result = _solved(content)
    assert result.products_shared == clean.products_shared - 1  # the fact the warning explains
    left = _warning(result, "placement_beyond_tolerance")
    (named,) = left.details["products"]
    assert named["global_id"] == moved and abs(named["placement_offset"] - 2e11) < 1e3
    assert named["spacing"] == 2 ** -15 and named["spacing"] > result.tolerance  # doubles at 2e11: 3.05e-5 apart
    members = {m for c in result.classes for m in c.members}
    assert named["looks_like"] in members and named["looks_like"] != moved
    assert moved in left.message and "2e+11 m from the origin" in left.message
    (far,) = _warning(result, "placement_outlier").details["products"]
    assert far["global_id"] == moved and not far["shares_geometry"] and far["distance"] > 1e11


def test_a_product_still_shared_at_5e10_is_named_as_far_from_the_rest():
    content, moved = _moved("5.E10")
    result = _solved(content)
    assert _warning(result, "placement_beyond_tolerance") is None  # it matched: nothing was left out
    (far,) = _warning(result, "placement_outlier").details["products"]
    assert far["global_id"] == moved and far["shares_geometry"] and abs(far["placement_offset"] - 5e10) < 1e3
    assert moved in {m for c in result.classes for m in c.members}


def test_far_is_judged_against_the_models_own_extent():
    # the tunnel's typical distance is some metres: 1e3 m away is a few hundred times it, 1e5 m tens of thousands
    near_enough, _ = _moved("1.E3")
    assert not PLACEMENT_CODES & {w.code for w in _solved(near_enough).report.warnings}
    far_off, moved = _moved("1.E5")
    result = _solved(far_off)
    (far,) = _warning(result, "placement_outlier").details["products"]
    assert far["global_id"] == moved and 1e3 < far["times_typical"] < 1e5


def test_a_georeferenced_model_is_neither_refused_nor_warned_about():
    root = b"#19=IFCCARTESIANPOINT((0.,0.,0.));"  # the root placement's origin (the site's): every product moves
    assert TUNNEL.count(root) == 1
    geo = TUNNEL.replace(root, b"#19=IFCCARTESIANPOINT((1.E9,-2.5E6,30.));")
    clean, result = _solved(TUNNEL), _solved(geo)
    assert result.report.status != "failed" and result.products_shared == clean.products_shared
    assert not PLACEMENT_CODES & {w.code for w in result.report.warnings}
    assert not PLACEMENT_CODES & {w.code for w in clean.report.warnings}
    zoo = _solved((EXAMPLES / "zoo_ifc2x3.ifc").read_bytes(), "zoo.ifc")
    assert zoo.products_shared and not PLACEMENT_CODES & {w.code for w in zoo.report.warnings}
