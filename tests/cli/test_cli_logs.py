"""Log hygiene: a command's standard error holds its own lines; the run's log lines, third-party libraries' (pint
redefining a unit) and Python warnings appear only with ``--log-level``. In the service every such line is a
JSON line of its log."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from tests.conftest import REPO, run_plantsolve

# what a library does while the command runs: a logger line (pint's, at import) and a Python warning
NOISE = ("import logging, warnings\n"
         "logging.getLogger('pint.util').warning(\"Redefining 'permille'\")\n"
         "warnings.warn('a library warns', UserWarning)\n")


def _python(code: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, cwd=REPO)


def test_third_party_lines_reach_a_commands_stderr_only_when_asked():
    quiet = _python("from plantsolve.cli import _configure_logs\n_configure_logs(['solve', 'k', 'in.json'])\n" + NOISE)
    assert quiet.returncode == 0 and quiet.stderr == "", quiet.stderr
    asked = _python("from plantsolve.cli import _configure_logs\n"
                    "_configure_logs(['solve', 'k', 'in.json', '--log-level', 'warning'])\n" + NOISE)
    assert asked.stderr.splitlines()[0] == "WARNING pint.util: Redefining 'permille'", asked.stderr
    assert "WARNING py.warnings:" in asked.stderr and "a library warns" in asked.stderr
    errors_only = _python("from plantsolve.cli import _configure_logs\n"
                          "_configure_logs(['solve', 'k', 'in.json', '--log-level', 'error'])\n" + NOISE)
    assert errors_only.stderr == ""


def test_the_services_log_is_json_third_party_lines_and_warnings_included():
    done = _python("from plantsolve.workers.logs import configure_logging\nconfigure_logging('json', 'info')\n"
                   + NOISE + "logging.getLogger('plantsolve.api').info('ours')\n"
                   "logging.getLogger('matplotlib').info('below warning: not written')\n")
    lines = [json.loads(line) for line in done.stderr.splitlines()]  # every line is JSON
    assert [(line["logger"], line["level"]) for line in lines] == [
        ("pint.util", "WARNING"), ("py.warnings", "WARNING"), ("plantsolve.api", "INFO")], done.stderr
    assert lines[0]["message"] == "Redefining 'permille'" and "a library warns" in lines[1]["message"]


def test_a_host_applications_root_logging_is_left_to_it():
    done = _python("import logging\nlogging.basicConfig(format='HOST %(name)s %(message)s')\n"
                   "from plantsolve.workers.logs import configure_logging\nconfigure_logging('json', 'info')\n" + NOISE)
    assert done.stderr.splitlines()[0] == "HOST pint.util Redefining 'permille'", done.stderr
    assert not any(line.startswith("{") for line in done.stderr.splitlines())


def test_solve_prints_its_own_lines_and_the_runners_only_with_log_level(tmp_path: Path):
    request = tmp_path / "request.json"
    request.write_text(json.dumps({"values": [1.0, -2.0]}))
    done = run_plantsolve(["solve", "test-compute", str(request), "-o", str(tmp_path / "out.json")], tmp_path,
                          plugins=True)
    assert done.returncode == 0, done.stderr
    lines = done.stderr.splitlines()
    assert [line.split(" ")[0] for line in lines] == ["artifacts:", "warning", "job"], done.stderr
    assert lines[1] == "warning [negative]: Some values are negative."
    loud = run_plantsolve(["solve", "test-compute", str(request), "-o", str(tmp_path / "out.json"),
                           "--log-level", "info"], tmp_path, plugins=True)
    assert loud.returncode == 0 and "INFO plantsolve.runner:" in loud.stderr and "attempt 1 started" in loud.stderr
