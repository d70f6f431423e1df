"""Concurrent submissions on the embedded SQLite default lose nothing."""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

from tests.conftest import wait_for


def test_fifty_threads_submit_and_every_job_completes(client):
    def submit(i: int) -> tuple[int, str]:
        response = client.post("/v1/test-compute/jobs", json={"values": [float(i), 0.5]}, headers={"Idempotency-Key": f"k-{i}"})
        return response.status_code, response.json()["id"]

    with ThreadPoolExecutor(max_workers=50) as pool:
        submitted = list(pool.map(submit, range(50)))
    assert [status for status, _ in submitted] == [202] * 50
    ids = [job_id for _, job_id in submitted]
    assert len(set(ids)) == 50
    for i, job_id in enumerate(ids):
        wait_for(client, job_id, timeout=60)
        assert client.get(f"/v1/jobs/{job_id}/result").json()["total"] == i + 0.5
    listed, cursor = set(), None
    while True:
        page = client.get("/v1/jobs", params={"limit": 200, **({"cursor": cursor} if cursor else {})}).json()
        listed |= {item["id"] for item in page["items"]}
        if not (cursor := page["next_cursor"]):
            break
    assert listed == set(ids)


def test_same_idempotency_key_from_many_threads_makes_one_job(client):
    def submit(_: int) -> tuple[int, str]:
        response = client.post("/v1/test-compute/jobs", json={"values": [7.0]}, headers={"Idempotency-Key": "same"})
        return response.status_code, response.json()["id"]

    with ThreadPoolExecutor(max_workers=20) as pool:
        results = list(pool.map(submit, range(20)))
    assert len({job_id for _, job_id in results}) == 1
    assert sorted(status for status, _ in results) == [200] * 19 + [202]
