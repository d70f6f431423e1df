"""Progress rises smoothly in every solver of alignment, tube, perfmap and polyhedra: each stage and
iteration block reports, the fractions never go down, no single report jumps far, and the last is 1."""

from __future__ import annotations

import pytest

from plantsolve.solvers import alignment, perfmap, polyhedra, tube
from plantsolve.solvers.stages import Stages


def record(spec, body: dict) -> list[tuple[float, str]]:
    seen: list[tuple[float, str]] = []
    spec.solve(spec.request_model.model_validate(body), lambda f, m="": seen.append((float(f), m)))
    return seen


def check(seen: list[tuple[float, str]], min_steps: int, max_jump: float) -> None:
    fractions = [f for f, _ in seen]
    assert all(0.0 <= f <= 1.0 for f in fractions)
    assert all(b >= a for a, b in zip(fractions, fractions[1:])), fractions
    assert len(set(fractions)) >= min_steps, seen
    jumps = [b - a for a, b in zip([0.0] + fractions, fractions)]
    assert max(jumps) <= max_jump, seen
    assert fractions[-1] == 1.0
    assert all(m for _, m in seen)  # every report says what it is doing


@pytest.mark.parametrize("spec, body, min_steps, max_jump", [
    (perfmap.SPEC, perfmap.SPEC.example(), 15, 0.2),
    (alignment.SPEC, alignment.SPEC.example(), 8, 0.3),
    (alignment.SPEC, {**alignment.SPEC.example(), "options": {"method": "dual_quaternion"}}, 8, 0.3),
    (tube.SPEC, tube.SPEC.example(), 20, 0.15),
    (polyhedra.SPEC, polyhedra.SPEC.example(), 8, 0.26),
], ids=["perfmap", "alignment-direct", "alignment-dual-quaternion", "tube", "polyhedra"])
def test_progress_rises_smoothly(spec, body, min_steps, max_jump):
    check(record(spec, body), min_steps, max_jump)


def test_stages_step_creep_and_never_go_back():
    seen = []
    st = Stages(lambda f, m="": seen.append(f))
    st.stage(0.0, 0.5, "a")
    st.step(1, 4)
    st.tick()
    st.tick()
    # the second tick is at 0.5 - 0.5 * 0.85 ** 2; the first (0.075) would go back and is held at 0.125
    assert seen == pytest.approx([0.0, 0.125, 0.125, 0.5 - 0.5 * 0.85 ** 2])
    st.stage(0.5, 1.0, "b")
    for _ in range(200):
        st.tick()
    assert seen[-1] < 1.0 and seen[-1] == pytest.approx(1.0, abs=1e-9)
    st.stage(0.2, 0.3, "late")  # a stage that starts below the last report does not move it back
    assert seen[-1] >= 0.99
    st.done()
    assert seen[-1] == 1.0
