"""bench/alignment.py --steps: what the iteration count of the direct method is made of. Every refinement step of
the round's KKT solves is one of ``iterations``, and a closing round of a plant-like network runs its joint stage to
the cap of its Gauss-Newton steps (the crawl below what snapping closes fills what the earlier phases leave), which
is why the count follows the hardest loop and not the network's size."""

from __future__ import annotations

import importlib.util

from tests.conftest import REPO


def _bench():
    spec = importlib.util.spec_from_file_location("alignment_bench", REPO / "bench" / "alignment.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_traced_refinement_steps_are_the_iterations_and_the_joint_stage_runs_to_its_cap():
    bench = _bench()
    r = bench.run_case(18, "direct", None, family="plant", steps=True)  # 740 components, in a child process
    assert r["converged"] and r["cuts"] == 0 and r["stop"] == "all connections closed"
    solves = r["solves"]
    rotation = [s for s in solves if s["stage"] == "solve_rotations"]
    joint = [s for s in solves if s["stage"] == "solve_joint"]
    assert len(rotation) + len(joint) == len(solves)  # one round, no continuation
    assert sum(s["steps"] for s in solves) == r["iterations"]
    assert len(joint) == 25  # solve_joint's max_gn: the crawl stops at the cap, not at a threshold
    phases = [s["phase"] for s in joint]
    assert phases[0] == "cost" and phases[-1] == "crawl"
    assert phases.index("crawl") > phases.index("cost")
    crawl = [s for s in joint if s["phase"] == "crawl"]
    assert max(s["start"] for s in crawl) < min(s["start"] for s in joint if s["phase"] == "cost")
    said = bench._steps_said(solves)
    assert said[0].split()[0] == "rotation" and f"{len(rotation)} GN steps" in said[0]
    assert sum(int(line.split(",")[1].split()[0]) for line in said) == r["iterations"]


def test_the_exponent_is_the_slope_of_cpu_time_over_components_on_log_scales():
    bench = _bench()
    small, large = {"components": 1000, "cpu_s": 2.0}, {"components": 4000, "cpu_s": 8.0 * 2 ** 0.1}
    assert bench._exponent(small, large, "cpu_s") == "1.05"
    assert bench._exponent(None, large, "cpu_s") == ""
