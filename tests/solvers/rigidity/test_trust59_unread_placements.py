"""Placements the LDraw reader skips (a matrix that scales, a position not finite, a line cut) are parts the analysis
never saw: when they and the unknown parts are half of the model or more, rigidity is NOT DETERMINED, as for unknown
parts. Before, two bricks of which one was placed by a scaling matrix were 'rigid: true, dof 0' (one brick alone)."""

from __future__ import annotations

import numpy as np
import pytest

from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.rigidity import upload
from plantsolve.solvers.rigidity.solve import solve
from plantsolve.solvers.rigidity.upload import MAX_DEPTH, MAX_PARTS, parse_upload
from plantsolve.solvers.rigidity.verdicts import coverage_verdict

IDENTITY = "1 0 0 0 1 0 0 0 1"


def brick(y: float, matrix: str = IDENTITY, x: str = "0") -> str:
    return f"1 16 {x} {y:g} 0 {matrix} 3001.dat\n"


def solved(text: str, name: str = "model.ldr"):
    request = parse_upload(StoredInput.from_bytes(name, text.encode()), None)
    return request, solve(request).result


def codes(result) -> list[str]:
    return [w.code for w in result.report.warnings]


@pytest.mark.parametrize("second", [brick(-24, "2 0 0 0 2 0 0 0 2"), brick(-24, x="nan"), brick(-24, x="1e300"),
                                    brick(-24, "0 0 0 0 0 0 0 0 0")])
def test_one_of_two_bricks_not_read_leaves_rigidity_not_determined(second):
    request, result = solved(brick(0) + second)
    assert request.source["placements_not_read"] == 1
    assert result.rigid is None and codes(result)[0] == "rigidity_not_determined"
    (verdict,) = [w for w in result.report.warnings if w.code == "rigidity_not_determined"]
    assert verdict.details["placements_not_read"] == 1 and verdict.details["known_parts"] == 1
    assert "skipped_lines" in codes(result)


def test_one_unread_brick_of_a_stack_of_nine_keeps_the_verdict():
    text = "".join(brick(-24 * k) for k in range(8)) + brick(-24 * 8, x="nan")
    request, result = solved(text)
    assert request.source["placements_not_read"] == 1
    assert result.rigid is True and result.dof == 0 and "rigidity_not_determined" not in codes(result)


def test_a_line_of_a_sub_model_placed_three_times_counts_each_placement():
    text = ("0 FILE main.ldr\n" + "".join(f"1 16 0 {-24 * k} 0 {IDENTITY} pair.ldr\n" for k in range(3))
            + "0 FILE pair.ldr\n" + brick(0) + brick(-24, "2 0 0 0 2 0 0 0 2"))
    request, result = solved(text, "model.mpd")
    assert request.source["placements_not_read"] == 3 and len(request.parts) == 3
    assert result.rigid is None and codes(result)[0] == "rigidity_not_determined"


def test_a_missing_sub_model_is_said_by_its_own_verdict_not_counted_as_unread():
    request, result = solved("0 FILE main.ldr\n" + brick(0) + brick(-24) + f"1 16 0 24 0 {IDENTITY} lost.ldr\n",
                             "model.mpd")
    assert request.source["placements_not_read"] == 0
    assert codes(result)[0] == "submodels_missing" and "rigidity_not_determined" not in codes(result)


def test_a_sub_model_placed_by_a_scaling_matrix_counts_every_part_it_holds():
    # its one line placed six bricks: counted as one, the two bricks read were 'rigid: true' for a model of eight
    text = ("0 FILE main.ldr\n" + brick(0) + brick(-24) + "1 16 0 -48 0 2 0 0 0 2 0 0 0 2 tower.ldr\n"
            + "0 FILE tower.ldr\n" + "".join(brick(-24 * k) for k in range(5)) + f"1 16 0 -120 0 {IDENTITY} top.ldr\n"
            + "0 FILE top.ldr\n" + brick(0) + "1 16 0 0 0 1 0 0 0 1 0 0 0 1 stud.dat\n")
    request, result = solved(text, "model.mpd")
    assert request.source["placements_not_read"] == 6 and len(request.parts) == 2
    assert result.rigid is None and codes(result)[0] == "rigidity_not_determined"
    (verdict,) = [w for w in result.report.warnings if w.code == "rigidity_not_determined"]
    assert verdict.details["placements_not_read"] == 6 and verdict.details["unknown_share"] == pytest.approx(0.75)
    assert "6 part(s) placed by lines that could not be read" in verdict.message


def chain(depth: int, first: str = IDENTITY) -> str:
    """A brick in every one of ``depth`` + 2 sub-models, each placing the next one brick higher."""
    text = "0 FILE main.ldr\n" + brick(0) + f"1 16 0 -24 0 {first} s0.ldr\n"
    for d in range(depth):
        text += f"0 FILE s{d}.ldr\n" + brick(0) + f"1 16 0 -24 0 {IDENTITY} s{d + 1}.ldr\n"
    return text + f"0 FILE s{depth}.ldr\n" + brick(0)


def test_sub_models_nested_past_the_depth_limit_count_the_parts_they_hold():
    request = parse_upload(StoredInput.from_bytes("model.mpd", chain(40).encode()), None)
    assert len(request.parts) == MAX_DEPTH  # the bricks read, the rest past the line nested too deep
    assert request.source["placements_not_read"] == 42 - MAX_DEPTH  # 42 bricks: none lost, none counted twice


def test_a_fan_out_of_sub_models_placed_by_a_scaling_matrix_counts_at_most_one_more_than_the_limit():
    text = "0 FILE main.ldr\n" + brick(0) + "1 16 0 -24 0 2 0 0 0 2 0 0 0 2 l0.ldr\n"
    for d in range(30):  # ten placements a level, thirty levels: 10^30 parts
        text += f"0 FILE l{d}.ldr\n" + "".join(f"1 16 0 {-24 * k} 0 {IDENTITY} l{d + 1}.ldr\n" for k in range(10))
    request, result = solved(text + "0 FILE l30.ldr\n" + brick(0), "model.mpd")
    assert request.source["placements_not_read"] == MAX_PARTS + 1
    (verdict,) = [w for w in result.report.warnings if w.code == "rigidity_not_determined"]
    assert f"more than {MAX_PARTS} part(s) placed by lines that could not be read" in verdict.message


def test_parts_past_the_parts_limit_are_said_as_such_not_as_lines_not_read(monkeypatch):
    monkeypatch.setattr(upload, "MAX_PARTS", 2)
    request = parse_upload(StoredInput.from_bytes("model.ldr", "".join(brick(-24 * k) for k in range(5)).encode()),
                           None)
    assert len(request.parts) == 2 and request.source["parts_past_limit"] == 3
    assert request.source["placements_not_read"] == 0
    verdict = coverage_verdict(2, [], np.zeros((0, 3)), 0, 3)
    assert verdict.details["parts_past_limit"] == 3
    assert f"3 part(s) past the reader's limit of {MAX_PARTS} parts" in verdict.message
    assert "could not be read" not in verdict.message
