"""The pause before trying again what failed several times in a row."""

from __future__ import annotations

from plantsolve.jobs.backoff import FORKSERVER_RESTARTS, UNCLAIMED_RESTARTS, Backoff


def test_no_pause_after_a_first_failure_then_doubling_up_to_the_longest():
    backoff = Backoff(first=1.0, longest=8.0)
    assert [backoff.pause(n) for n in range(7)] == [0.0, 0.0, 1.0, 2.0, 4.0, 8.0, 8.0]


def test_a_cause_that_lasts_for_days_keeps_the_longest_pause():
    # a forkserver dying every 30 s for a day is ~2900 failures in a row: 2.0 ** 2898 does not fit a float
    assert Backoff(first=1.0, longest=30.0).pause(2900) == 30.0
    assert UNCLAIMED_RESTARTS.pause(10**6) == UNCLAIMED_RESTARTS.longest == 30.0


def test_the_forkserver_and_a_job_dying_before_its_claim_pause_as_runtime58_did():
    for backoff in (FORKSERVER_RESTARTS, UNCLAIMED_RESTARTS):
        assert [backoff.pause(n) for n in (1, 2, 3, 7, 8)] == [0.0, 1.0, 2.0, 30.0, 30.0]
