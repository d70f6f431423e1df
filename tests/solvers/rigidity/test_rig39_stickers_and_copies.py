"""Stickers are left out of the analysis and named (not unknown parts); copies of a part at one pose beyond the first
repeat are left out, so that many copies at one spot cost what two do."""

from __future__ import annotations

import sys

from plantsolve.schemas.rigidity import PartIn, RigidityRequest
from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.rigidity.solve import solve
from plantsolve.solvers.rigidity.stickers import category, is_sticker, official_stickers
from plantsolve.solvers.rigidity.upload import parse_upload

# two 2 x 4 bricks, one on the other's eight studs (rigid), and stickers on their faces: the library's 004452e
# ("=Sticker  1 x  1 Fire Emblem", twice) and 59718a ("Sticker  0.6 x  4 with Yellow/Black Chevrons")
BRICKS_AND_STICKERS = """0 two bricks and three stickers
1 4 0 0 0 1 0 0 0 1 0 0 0 1 3001.dat
1 4 0 -24 0 1 0 0 0 1 0 0 0 1 3001.dat
1 15 0 -12 -10.25 1 0 0 0 1 0 0 0 1 004452e.dat
1 15 0 12 -10.25 1 0 0 0 1 0 0 0 1 004452e.dat
1 15 0 -12 10.25 1 0 0 0 1 0 0 0 1 59718a.dat
"""


def parse(text: str) -> RigidityRequest:
    return parse_upload(StoredInput.from_bytes("model.mpd", text.encode()), None)


def warning(result, code):
    return next(w for w in result.report.warnings if w.code == code)


def test_bricks_with_as_many_stickers_get_a_verdict_and_the_stickers_are_named():
    result = solve(parse(BRICKS_AND_STICKERS)).result
    # the two bricks on eight studs: one rigid joint, dof 0, one piece; before, the three stickers were unknown
    # parts, three elements of five, and the model NOT DETERMINED
    assert (result.rigid, result.dof, len(result.joints), len(result.pieces)) == (True, 0, 1, 1)
    assert result.unknown_parts == [] and result.report.verdict is None
    assert [p.id for p in result.parts] == ["L2", "L3"]
    stickers = warning(result, "stickers")
    assert stickers.details == {"count": 3, "parts": {"004452e": 2, "59718a": 1}, "ids": ["L4", "L5", "L6"]}
    assert "004452e (2), 59718a (1)" in stickers.message
    assert "unknown_parts" not in [w.code for w in result.report.warnings]


def test_a_part_the_catalogue_lacks_stays_unknown_beside_stickers():
    result = solve(parse(BRICKS_AND_STICKERS + "1 15 200 0 0 1 0 0 0 1 0 0 0 1 99999x.dat\n")).result
    assert [u.part for u in result.unknown_parts] == ["99999x"]
    assert warning(result, "stickers").details["count"] == 3


def test_a_sticker_the_file_defines_is_recognised_from_its_header():
    text = ("0 FILE model.ldr\n" + BRICKS_AND_STICKERS.split("\n", 1)[1]
            + "1 15 0 -12 -10.25 1 0 0 0 1 0 0 0 1 logo.dat\n"
            "0 FILE logo.dat\n0 ~Sticker  1 x  1 with Club Logo\n0 Name: logo.dat\n0 !LDRAW_ORG Unofficial_Part\n"
            "4 16 -9 -0.25 -9 9 -0.25 -9 9 -0.25 9 -9 -0.25 9\n"
            "0 FILE plain.dat\n0 Panel 1 x 1 Custom\n0 !LDRAW_ORG Unofficial_Part\n"
            "4 16 -9 -0.25 -9 9 -0.25 -9 9 -0.25 9 -9 -0.25 9\n")
    text = text.replace("0 FILE logo.dat", "1 15 40 0 0 1 0 0 0 1 0 0 0 1 plain.dat\n0 FILE logo.dat")
    request = parse(text)
    assert request.source["stickers_defined"] == ["logo"]
    result = solve(request).result
    assert warning(result, "stickers").details["parts"] == {"004452e": 2, "59718a": 1, "logo": 1}
    assert [u.part for u in result.unknown_parts] == ["plain"]  # a custom part that is no sticker stays unknown


def test_the_sticker_category_as_ldraw_states_it():
    assert category(["0 =Sticker  1 x  1 Fire Emblem", "0 Name: 004452e.dat"]) == "Sticker"
    assert category(["0 Slope Brick Curved  2 x  1 with Tail Light Sticker",
                     "0 !CATEGORY Sticker Shortcut"]) == "Sticker Shortcut"  # a part with its sticker applied
    assert category(["0 ~Sticker  1 x  1 with Club Logo"]) == "Sticker"
    stickers = official_stickers()
    assert len(stickers) == 1847  # the LDraw 2024-05 library's parts of category Sticker
    assert is_sticker("004452e") and is_sticker("59718a")
    assert not is_sticker("3001") and not is_sticker("11477d01")  # a brick; a sticker shortcut
    assert is_sticker("logo", defined={"logo"})


def plates(copies: int) -> RigidityRequest:
    return RigidityRequest(parts=[PartIn(id=f"p{k}", part="3024", position=[0, 0, 0]) for k in range(copies)])


def test_copies_beyond_the_first_repeat_are_left_out_and_counted():
    result = solve(plates(4)).result
    # p0 and its first repeat p1 are analysed as before (two plates in one space: a collision, two pieces);
    # p2 and p3 add nothing but the same again
    assert [p.id for p in result.parts] == ["p0", "p1"]
    assert [c.bodies for c in result.collisions] == [["p0", "p1"]]
    duplicates = warning(result, "duplicate_parts")
    assert duplicates.details["pairs"] == [["p0", "p1"], ["p0", "p2"], ["p0", "p3"]]
    assert (duplicates.details["left_out"], duplicates.details["left_out_ids"]) == (2, ["p2", "p3"])
    assert result.unknown_parts == []


def _calls(copies: int) -> int:
    """Python function calls of one solve of ``copies`` plates at one spot (a second solve: caches warm)."""
    request = plates(copies)
    solve(request)
    count = 0

    def hook(frame, event, arg):
        nonlocal count
        count += event == "call"

    sys.setprofile(hook)
    try:
        solve(request)
    finally:
        sys.setprofile(None)
    return count


def test_many_copies_at_one_spot_cost_a_bounded_count_per_copy():
    """Every copy was matched against every other (connection lookup, collisions, spacing checks): 100 copies
    made about 0.75 million calls, 1,500 copies two minutes. Now each copy costs its place in the duplicate
    search only (about 90 calls)."""
    per_copy = (_calls(100) - _calls(10)) / 90
    assert per_copy < 150


def test_the_generator_lists_the_stickers_of_a_library(tmp_path):
    import gzip
    import importlib.util
    from pathlib import Path

    script = Path(__file__).resolve().parents[3] / "scripts" / "ldcad_catalogue.py"
    spec = importlib.util.spec_from_file_location("ldcad_catalogue", script)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    parts = tmp_path / "parts"
    (parts / "s").mkdir(parents=True)
    files = {"900a.dat": "0 Sticker  1 x  2 with Stripes\n", "900b.dat": "0 =Sticker  1 x  1 Logo\n",
             "900c.dat": "0 Tile 1 x 2 with Logo\n0 !CATEGORY Sticker\n",  # a category line decides
             "900d.dat": "0 Brick 1 x 2 with Logo Sticker\n0 !CATEGORY Sticker Shortcut\n",
             "900e.dat": "0 Brick 1 x 2\n", "s/900as01.dat": "0 ~Sticker  1 x  2 Subpart\n"}
    for name, text in files.items():
        (parts / name).write_text(text)
    out = tmp_path / "stickers.txt.gz"
    assert module.main(["--ldraw", str(tmp_path), "--stickers", str(out), "--source", "test"]) == 0
    lines = gzip.decompress(out.read_bytes()).decode().splitlines()
    assert lines == ['{"source": "test"}', "900a", "900b", "900c"]  # no shortcut, brick or subpart
