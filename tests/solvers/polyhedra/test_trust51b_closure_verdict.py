"""A zone without a volume is a verdict against the result, not a caveat: a job whose zone was left open (a surface
skipped by its reader, a file cut after the first zone, a surface given twice) 'succeeded' with status 'warning' and
no verdict, so the job view, the CLI's exit status and the dashboard read it as a pass while total_volume was null."""

from __future__ import annotations

import pytest

from tests.conftest import REPO, wait_for

IDF = (REPO / "examples" / "polyhedra" / "two_offices.idf").read_bytes()


def _without_office_a_roof(text: bytes) -> bytes:
    start = text.index(b"BuildingSurface:Detailed,\n  Office A Roof")
    return text[:start] + text[text.index(b"\n\n", start) + 2:]


def _submitted(client, name: str, content: bytes) -> tuple[dict, dict]:
    response = client.post("/v1/polyhedra/jobs", files={"file": (name, content)})
    assert response.status_code == 202, response.text
    job = wait_for(client, response.json()["id"], timeout=60)
    assert job["status"] == "succeeded", job
    return job, client.get(f"/v1/jobs/{job['id']}/result").json()


def test_an_open_zone_is_a_not_determined_verdict_naming_it_and_closed_zones_are_none_through_the_api(client):
    job, result = _submitted(client, "offices.idf", _without_office_a_roof(IDF))
    volumes = {z["id"]: z["volume"] for z in result["zones"]}
    assert volumes == {"Office A Thermal Zone": None, "Office B Thermal Zone": pytest.approx(60.0)}
    assert result["total_volume"] is None
    verdict = result["report"]["verdict"]
    assert verdict["code"] == "volume_not_determined" and verdict["label"] == "NOT DETERMINED"
    assert "'Office A Thermal Zone': not closed, 4 open edge(s)" in verdict["message"]
    assert "Office B" not in verdict["message"] and "1 of 2 zone(s)" in verdict["message"]
    assert job["report"]["verdict"] == verdict  # the job view says it beside 'succeeded'
    assert result["report"]["warnings"][0]["details"] == {"zones": ["Office A Thermal Zone"], "zones_total": 2}
    _, result = _submitted(client, "offices.idf", IDF)  # closed zones: no verdict
    assert result["total_volume"] == pytest.approx(120.0) and result["report"]["verdict"] is None


def test_a_surface_given_twice_says_why_the_volume_is_missing():
    from plantsolve.solvers.base import StoredInput
    from plantsolve.solvers.polyhedra.solve import solve
    from plantsolve.solvers.polyhedra.upload import parse_upload

    start = IDF.index(b"BuildingSurface:Detailed,\n  Office B Roof")
    roof = IDF[start:IDF.index(b"\n\n", start)].replace(b"Office B Roof", b"Office B Roof again")
    result = solve(parse_upload(StoredInput.from_bytes("b.idf", IDF + b"\n" + roof + b"\n"), None)).result
    assert result.report.verdict.code == "volume_not_determined"
    assert "'Office B Thermal Zone': faces listed twice" in result.report.verdict.message


def test_the_verdict_code_is_one_the_schema_counts_as_a_verdict():
    from plantsolve.schemas.common import VERDICT_CODES

    assert VERDICT_CODES["volume_not_determined"] == "NOT DETERMINED"


