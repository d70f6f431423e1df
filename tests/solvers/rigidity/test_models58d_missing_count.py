"""A file placing more missing sub-models than the reader lists (MAX_SKIPPED_LISTED) is said to place all of them: the
reader records their count in ``source.missing_submodels_count``, and the verdict counted the names kept (200)."""

from __future__ import annotations

from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.rigidity.solve import solve
from plantsolve.solvers.rigidity.upload import MAX_SKIPPED_LISTED, parse_upload


def test_the_verdict_counts_every_missing_submodel_not_the_names_kept():
    n = MAX_SKIPPED_LISTED + 37
    text = "0 FILE tower.ldr\n1 4 0 0 0 1 0 0 0 1 0 0 0 1 3001.dat\n" + "".join(
        f"1 4 0 {-24 * (k + 1)} 0 1 0 0 0 1 0 0 0 1 gone{k}.ldr\n" for k in range(n))
    request = parse_upload(StoredInput.from_bytes("tower.mpd", text.encode()), None)
    assert request.source["missing_submodels_count"] == n and len(request.source["missing_submodels"]) == 200
    verdict = solve(request).result.report.warnings[0]
    assert verdict.code == "submodels_missing"
    assert f"places {n} sub-model(s) it does not hold — 'gone0.ldr' (line 3)" in verdict.message  # before: 200
    assert f"({MAX_SKIPPED_LISTED} listed in details)" in verdict.message
    assert len(verdict.details["missing_submodels"]) == MAX_SKIPPED_LISTED


def test_a_count_short_of_the_names_or_not_a_number_says_the_names():
    text = "0 FILE tower.ldr\n1 4 0 0 0 1 0 0 0 1 0 0 0 1 3001.dat\n1 4 0 -24 0 1 0 0 0 1 0 0 0 1 gone.ldr\n"
    request = parse_upload(StoredInput.from_bytes("tower.mpd", text.encode()), None)
    for count in (0, "many", None):
        written = request.model_copy(update={"source": {**request.source, "missing_submodels_count": count}})
        message = solve(written).result.report.warnings[0].message
        assert "places 1 sub-model(s) it does not hold — 'gone.ldr' (line 3):" in message
