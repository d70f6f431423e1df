"""The curl line of examples/tube/INSPECTION.md, run as written (bash, curl, python3 from the repository root)
against a real server: the job is accepted with the nominal CSV whole. The same line with ``-F`` for the options
is the 422 it answered before (curl cuts a ``-F`` value at ``;``)."""

from __future__ import annotations

import json
import re
import shutil
import subprocess

import httpx
import pytest

from plantsolve.app.main import create_app
from tests.conftest import REPO, service_settings
from tests.support.live import live_server

DOC = REPO / "examples" / "tube" / "INSPECTION.md"


def _documented_command() -> str:
    blocks = re.findall(r"```bash\n(.*?)```", DOC.read_text(), re.S)
    commands = [block for block in blocks if "curl" in block and "/v1/tube/jobs" in block]
    assert len(commands) == 1, blocks
    return commands[0]


def _run(command: str, base: str) -> subprocess.CompletedProcess:
    command = command.strip().replace("localhost:8000", base) + " -s -w '\\n%{http_code}'"
    return subprocess.run(["bash", "-c", command.replace("\\\n", " ")], cwd=REPO, capture_output=True, text=True,
                          timeout=60)


@pytest.mark.skipif(shutil.which("curl") is None or shutil.which("python3") is None, reason="needs curl and python3")
def test_the_documented_curl_line_submits_the_nominal_whole(tmp_path):
    command = _documented_command()
    assert "--form-string \"options=" in command
    app = create_app(service_settings(tmp_path), run_jobs=False)  # accepted is enough: nothing needs to run
    with live_server(app) as base:
        done = _run(command, base)
        body, status = done.stdout.rsplit("\n", 1)
        assert status == "202", done.stdout + done.stderr
        job = json.loads(body)
        options = httpx.get(f"{base}/v1/jobs/{job['id']}/input").json()["options"]
        assert options["pipe_radius"] == 6.0
        assert options["nominal_csv"] == (REPO / "examples/tube/nominal_xyz_clr.csv").read_text()

        cut = _run(command.replace("--form-string \"options=", "-F \"options="), base)
        body, status = cut.stdout.rsplit("\n", 1)
        assert status == "422" and json.loads(body)["errors"][0]["loc"][0] == "options", cut.stdout
