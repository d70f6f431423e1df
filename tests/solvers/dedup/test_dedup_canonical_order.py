"""The candidates' canonical order is their GlobalIds' order; only products that repeat a GlobalId are told
apart by their world centre and points (whose bytes are then made)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from plantsolve.solvers.dedup.congruence import Candidate
from plantsolve.solvers.dedup.grouping import canonical_order
from plantsolve.solvers.dedup.matching import make_shape


def _candidates(global_ids: list[str], seed: int) -> list[Candidate]:
    rng = np.random.default_rng(seed)
    return [Candidate(SimpleNamespace(GlobalId=g), ("IfcWall",), make_shape(rng.normal(size=(5, 3)) + rng.integers(3)))
            for g in global_ids]


def _by_full_key(candidates: list[Candidate]) -> list[Candidate]:
    return sorted(candidates, key=lambda c: (str(c.product.GlobalId), c.shape.centre.tolist(), c.shape.points.tobytes()))


def test_unique_global_ids_give_their_order():
    candidates = _candidates([f"g{i:03d}" for i in np.random.default_rng(1).permutation(60)], 2)
    got = canonical_order(candidates)
    assert [c.product.GlobalId for c in got] == sorted(c.product.GlobalId for c in candidates)
    assert [id(c) for c in got] == [id(c) for c in _by_full_key(candidates)]


def test_repeated_global_ids_are_ordered_by_their_geometry_whatever_the_input_order():
    ids = [f"g{i % 7}" for i in range(40)]
    candidates = _candidates(ids, 3)
    want = [id(c) for c in _by_full_key(candidates)]
    for seed in range(3):
        shuffled = [candidates[i] for i in np.random.default_rng(seed).permutation(len(candidates))]
        assert [id(c) for c in canonical_order(shuffled)] == want
