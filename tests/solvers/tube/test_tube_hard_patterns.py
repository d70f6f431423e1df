"""The hard scan patterns (short arcs on one die, two small bends far apart, nearly coplanar
back-to-back bends, seven bends three of them small) on single-view scans: the right topology, and values within the uncertainty the
solver reports, which is as much as the samples determine."""

from __future__ import annotations

import numpy as np
import pytest

from plantsolve.schemas.tube import TubeRequest
from plantsolve.solvers.tube.solve import solve
from plantsolve.solvers.tube.artifacts import model_from_result
from plantsolve.solvers.tube.model import build_spine, reverse_model, sample_centreline, spine_distance
from plantsolve.solvers.tube.synthetic import make_model, surface_samples

RP = 4.0
VIEW = np.array([0.3, -0.4, -1.0])


def run(rows, n=4000, seed=2, noise=0.012, **options):
    truth = make_model(rows, RP)
    pts = surface_samples(truth, n, np.random.default_rng(seed), view=VIEW, noise=noise * RP,
                          outlier_fraction=0.005)
    res = solve(TubeRequest.model_validate({"points": pts.tolist(), "options": options})).result
    got = model_from_result(res)
    if got.n_bends == truth.n_bends and np.abs(got.angles - reverse_model(truth).angles).sum() < np.abs(
            got.angles - truth.angles).sum():
        truth = reverse_model(truth)
    return truth, got, res


def undetermined(res) -> set[int]:
    return {b["bend"] - 1 for w in res.report.warnings if w.code == "bend_radius_undetermined"
            for b in w.details["bends"]}


SHORT_ARCS = [(30, 0, 18, 2.4 * RP), (20, 60, 15, 2.4 * RP), (24, -100, 20, 2.4 * RP), (30, 0, 0, 0)]


def test_short_arcs_on_one_die_radius_exact_at_low_noise():
    truth, got, res = run(SHORT_ARCS, noise=0.001)
    assert res.bend_radius_model.chosen == "common"
    assert np.all(np.abs(got.radii / truth.radii - 1) < 0.01)
    assert np.all(np.abs(np.degrees(got.angles - truth.angles)) < 0.01)


def test_short_arcs_radius_at_scan_noise_is_as_uncertain_as_reported():
    """Arcs shorter than the pipe radius: the die radius shows only in a sagitta of a few hundredths
    of r, so at 1.2 % noise its standard deviation is several percent and scales with the noise
    (the same scan at 0.1 % noise gives twelve times less). The error stays within the reported
    uncertainty and the bends are not flagged (a few percent is a determined radius)."""
    truth, got, res = run(SHORT_ARCS)
    low = run(SHORT_ARCS, noise=0.001)[2]
    assert res.bend_radius_model.chosen == "common"
    sigma = res.lra[0].sigma_bend_radius
    assert 0.02 < sigma / truth.radii[0] < 0.08
    assert 8 < sigma / low.lra[0].sigma_bend_radius < 16
    assert abs(got.radii[0] - truth.radii[0]) < 2.5 * sigma
    assert not undetermined(res)


SMALL_FAR = [(30, 0, 3.6, 3 * RP), (7 * RP, 45, 4.5, 3 * RP), (30, 0, 0, 0)]


def test_small_bends_far_apart_stay_two_bends_with_an_honest_radius():
    """3.6 and 4.5 degrees, 7 r apart, 45 degrees of rotation between: two bends, not one large arc;
    their radius is not determined by the samples, which the result says."""
    truth, got, res = run(SMALL_FAR)
    assert got.n_bends == 2
    assert np.all(np.abs(np.degrees(got.angles - truth.angles)) < 0.1)
    assert np.all(got.radii < 20 * RP)
    assert undetermined(res) == {0, 1}
    sd = np.array([r.sigma_bend_radius for r in res.lra[:-1]])
    assert np.all(np.abs(got.radii - truth.radii) < 3 * sd)


def test_small_bends_share_the_die_of_a_large_bend():
    """With a 70 degree bend on the same die the common radius pins the small bends too."""
    rows = [(30, 0, 70, 3 * RP), (6 * RP, 30, 3.6, 3 * RP), (7 * RP, 45, 4.5, 3 * RP), (30, 0, 0, 0)]
    truth, got, res = run(rows)
    assert got.n_bends == 3 and res.bend_radius_model.chosen == "common"
    assert np.all(np.abs(got.radii / truth.radii - 1) < 0.01)
    assert not undetermined(res)


B2B = [(5 * RP, 0, 112.6, 3 * RP), (0.23 * RP, 0.8, 89.7, 3 * RP), (5 * RP, 0, 0, 0)]


def test_nearly_coplanar_back_to_back_bends_stay_two_with_the_split_as_uncertain_as_reported():
    """112.6 and 89.7 degrees with 0.23 r of straight and 0.8 degrees of rotation between: two bends.
    The total turn is sharp; where it splits rests on the short straight between the arcs, and the
    reported angle sigmas say so (tenths of a degree, the sum's error a few hundredths)."""
    truth, got, res = run(B2B)
    assert got.n_bends == 2
    sa = np.array([r.sigma_angle for r in res.lra[:-1]])
    err = np.degrees(got.angles - truth.angles)
    assert np.all(np.abs(err) < 3 * sa) and np.all(sa < 0.6)
    assert abs(err.sum()) < 0.05
    c, _ = sample_centreline(got, RP / 4)
    d, _ = spine_distance(c, build_spine(truth))
    assert d.max() < 0.03 * RP


def test_free_radii_of_small_bends_are_flagged_not_confidently_wrong():
    """One radius per bend, forced: the small bends' radii are not determined. A free fit may leave one
    below the pipe radius with a sigma of a few percent (a spurious minimum of the folded torus there);
    the result flags it instead of presenting it as a measured radius."""
    rows = [(30, 0, 70, 3 * RP), (6 * RP, 30, 3.6, 3 * RP), (7 * RP, 45, 4.5, 3 * RP), (30, 0, 0, 0)]
    for seed in (2, 3):
        truth, got, res = run(rows, seed=seed, bend_radius_model="per_bend")
        big = int(np.argmax(got.angles))
        assert abs(got.radii[big] / truth.radii[big] - 1) < 0.01
        assert undetermined(res) == {0, 1, 2} - {big}


def test_free_radius_flags_do_not_hinge_on_round_off():
    """The same scan with every coordinate scaled by 1 + 1e-12, and with its samples shuffled: the free fit
    may stop in another minimum for a bend of a few degrees (seed 3 scaled: a radius of 150 r with a 2 %
    sigma instead of one below the pipe radius), but the bends it flags stay the small ones."""
    rows = [(30, 0, 70, 3 * RP), (6 * RP, 30, 3.6, 3 * RP), (7 * RP, 45, 4.5, 3 * RP), (30, 0, 0, 0)]
    truth = make_model(rows, RP)
    pts = surface_samples(truth, 4000, np.random.default_rng(3), view=VIEW, noise=0.012 * RP, outlier_fraction=0.005)
    for variant in (pts, pts * (1 + 1e-12), pts[np.random.default_rng(0).permutation(len(pts))]):
        res = solve(TubeRequest.model_validate({"points": variant.tolist(),
                                                "options": {"bend_radius_model": "per_bend"}})).result
        got = model_from_result(res)
        assert got.n_bends == 3
        assert undetermined(res) == {0, 1, 2} - {int(np.argmax(got.angles))}


@pytest.mark.parametrize("seed", [5003, pytest.param(5002, marks=pytest.mark.slow),
                                  pytest.param(5014, marks=pytest.mark.slow)])
def test_seven_bends_three_of_them_small_on_one_die_stay_seven(seed):
    """Seven bends on a 3 r die (pipe radius 20), three of 3.6-5 degrees, straights of 3-9 r: seven bends,
    not a sliver or half bend more left by a split on the subsample (seed 5003 gave a 0.15 degree bend
    at 4000, seed 5002 a 4.1 degree bend cut in three, seed 5014 a 4.8 degree bend cut in two halves both
    on the die, merged back only when refitted with the radii held to the die); every radius the die's,
    within 2 %, because the shared radius is the model the BIC keeps once no bend is invented; angles
    within 0.25 degrees."""
    from plantsolve.solvers.tube.synthetic import small_bends_tube

    rng = np.random.default_rng(seed)
    truth = small_bends_tube(rng)
    pts = surface_samples(truth, 6000, rng, view=rng.normal(size=3), noise=0.012 * truth.pipe_radius,
                          outlier_fraction=0.005)
    got = model_from_result(solve(TubeRequest(points=pts.tolist())).result)
    assert got.n_bends == 7, (np.degrees(got.angles), got.radii)
    if np.abs(got.angles - reverse_model(truth).angles).sum() < np.abs(got.angles - truth.angles).sum():
        truth = reverse_model(truth)
    assert np.all(np.abs(got.radii / 60.0 - 1) < 0.02), got.radii
    assert np.all(np.abs(np.degrees(got.angles - truth.angles)) < 0.25), np.degrees(got.angles)
