"""examples/client/submit_and_wait.py exits 3 for a job that succeeded with a verdict against its result (before: 0,
so a script could not tell a failed inspection from a pass), saving the result all the same, as the CLI does."""

from __future__ import annotations

import importlib.util
import json

import pytest

from plantsolve.app.main import create_app
from tests.conftest import REPO, service_settings
from tests.support.live import live_server

SCRIPT = REPO / "examples" / "client" / "submit_and_wait.py"


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    settings = service_settings(tmp_path_factory.mktemp("verdict"), events_poll_seconds=0.05,
                                plugins=["tests.support.kinds", "tests.cli.verdict_kind"])
    with live_server(create_app(settings)) as url:
        yield url


def _run(server: str, tmp_path, codes: list[str], monkeypatch, capsys) -> tuple[int, str, dict]:
    """The script's ``main`` as its command line runs it (in this process: a fresh interpreter costs seconds)."""
    spec = importlib.util.spec_from_file_location("submit_and_wait", SCRIPT)
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)
    request, out = tmp_path / "request.json", tmp_path / "result.json"
    request.write_text(json.dumps({"codes": codes}))
    monkeypatch.setattr("sys.argv", [str(SCRIPT), "--url", server, "test-verdict", str(request), "-o", str(out)])
    code = script.main()
    return code, capsys.readouterr().err, json.loads(out.read_text())


def test_a_failed_inspection_exits_3_with_the_result_saved(server, tmp_path, monkeypatch, capsys):
    code, err, result = _run(server, tmp_path, ["scan_gap", "inspection_failed"], monkeypatch, capsys)
    assert code == 3, err
    assert "[inspection_failed]" in err.splitlines()[-1] and "exit code 3" in err
    assert [w["code"] for w in result["report"]["warnings"]] == ["scan_gap", "inspection_failed"]


def test_a_caveat_is_no_verdict(server, tmp_path, monkeypatch, capsys):
    code, err, _ = _run(server, tmp_path, ["scan_gap"], monkeypatch, capsys)
    assert code == 0, err
