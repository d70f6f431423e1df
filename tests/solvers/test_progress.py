"""Progress rises in every kind's solver: each stage and iteration block reports, the fractions never go
down, no single report jumps far, the last is 1, and every report says what it is doing. Every kind in
the kind map runs (a new kind is covered the day it is registered); the bounds below are each kind's
own, set by how finely its example's stages report."""

from __future__ import annotations

import pytest

from plantsolve.solvers.kinds import KINDS
from plantsolve.solvers.stages import Stages

# kind -> (least distinct fractions, largest single rise) on its example; the flow meter's example is
# solved in closed form between two reports, and rigidity's stages are four
BOUNDS = {
    "perfmap": (15, 0.2),
    "alignment": (8, 0.3),
    "tube": (20, 0.15),
    "polyhedra": (8, 0.26),
    "dedup": (10, 0.3),
    "rigidity": (4, 0.4),
    "flowmeter": (4, 0.8),
}


def record(spec, body: dict) -> list[tuple[float, str]]:
    seen: list[tuple[float, str]] = []
    job_input = spec.input_of(spec.request_model.model_validate(body))
    spec.solve(job_input, lambda f, m="": seen.append((float(f), m)))
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


def test_every_kind_has_its_bounds():
    assert set(BOUNDS) == set(KINDS)


@pytest.mark.parametrize("kind", sorted(KINDS))
def test_progress_rises_smoothly(kind):
    spec = KINDS[kind]
    check(record(spec, spec.example()), *BOUNDS[kind])


def test_alignment_dual_quaternion_progress_rises_smoothly():
    spec = KINDS["alignment"]
    check(record(spec, {**spec.example(), "options": {"method": "dual_quaternion"}}), *BOUNDS["alignment"])


def test_a_cancelled_solve_stops_at_its_next_report():
    """Every kind passes the callback's exception on: a cancellation reaches each solver."""
    class Stop(Exception):
        pass

    for kind, spec in KINDS.items():
        calls = []

        def cancel(fraction, message=""):
            calls.append(fraction)
            if len(calls) == 2:
                raise Stop(kind)

        with pytest.raises(Stop):
            spec.solve(spec.input_of(spec.request_model.model_validate(spec.example())), cancel)
        assert len(calls) == 2, kind


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
