"""Screenshots of the dashboard for the README: the job list and a job's page, taken with headless
Chromium (Debian's ``chromium`` + ``chromium-driver``) from a fresh service with a few example jobs.

    .venv/bin/python scripts/dashboard_screenshots.py [--out docs/screenshots]
"""

from __future__ import annotations

import argparse
import json
import logging
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

import httpx  # noqa: E402

from plantsolve.app.main import create_app  # noqa: E402
from plantsolve.app.settings import AppSettings  # noqa: E402
from tests.support import browser  # noqa: E402

EXAMPLES = REPO / "examples"


def _wait(api: httpx.Client, job_id: str, timeout: float = 120) -> dict:
    deadline = time.monotonic() + timeout
    while True:
        view = api.get(f"/v1/jobs/{job_id}").json()
        if view["status"] in ("succeeded", "failed", "cancelled") or time.monotonic() > deadline:
            return view
        time.sleep(0.2)


def _jobs(api: httpx.Client) -> str:
    """A few jobs of several kinds, one of them rejected by the solver; returns the fan map's id."""
    submitted = [
        api.post("/v1/polyhedra/jobs", json=json.loads((EXAMPLES / "polyhedra" / "gable_house.json").read_text())),
        api.post("/v1/flowmeter/jobs", json=json.loads((EXAMPLES / "flowmeter" / "meter.json").read_text())),
        api.post("/v1/alignment/jobs", json=json.loads((EXAMPLES / "alignment" / "ladder.json").read_text())),
    ]
    with open(EXAMPLES / "perfmap" / "n3_fan_map.csv", "rb") as file:
        fan = api.post("/v1/perfmap/jobs", files={"file": ("n3_fan_map.csv", file)},
                       data={"options": json.dumps({"model": "cubic", "grid": [40, 40]})})
    for response in (*submitted, fan):
        response.raise_for_status()
        _wait(api, response.json()["id"])
    return fan.json()["id"]


def _running(api: httpx.Client) -> None:
    """A tube job left running while the list is shot (its progress bar moves on the page)."""
    job = api.post("/v1/tube/jobs", json=json.loads((EXAMPLES / "tube" / "scan_request.json").read_text()))
    job.raise_for_status()
    for _ in range(50):
        if api.get(f"/v1/jobs/{job.json()['id']}").json()["progress"]["fraction"] > 0.05:
            return
        time.sleep(0.1)


def _shoot(driver, url: str, path: Path, height: int, ready: str) -> None:
    driver.set_window_size(1400, height)
    driver.get(url)
    for _ in range(100):
        if driver.execute_script(ready):
            break
        time.sleep(0.1)
    time.sleep(0.5)  # let the bars' transitions settle
    driver.save_screenshot(str(path))
    print(f"wrote {path.relative_to(REPO) if path.is_relative_to(REPO) else path}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", type=Path, default=REPO / "docs" / "screenshots")
    args = parser.parse_args()
    reason = browser.missing()
    if reason:
        sys.exit(f"cannot take screenshots: {reason}")
    args.out.mkdir(parents=True, exist_ok=True)
    logging.getLogger("plantsolve").setLevel(logging.WARNING)  # the jobs' log lines are not what this prints
    with tempfile.TemporaryDirectory() as data:
        app = create_app(AppSettings(_env_file=None, data_dir=Path(data), embedded_mode="thread"))
        with browser.serve(app) as base, browser.chromium() as driver, httpx.Client(base_url=base, timeout=30) as api:
            fan = _jobs(api)
            _running(api)
            _shoot(driver, f"{base}/dashboard", args.out / "dashboard-list.png", 760,
                   "return document.querySelectorAll('tr[data-job]').length >= 5;")
            _shoot(driver, f"{base}/dashboard/jobs/{fan}", args.out / "dashboard-job.png", 1500,
                   "return [...document.querySelectorAll('.plots img')].every(i => i.complete && i.naturalWidth > 0);")


if __name__ == "__main__":
    main()
