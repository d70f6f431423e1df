"""``plantsolve`` CLI: solve runs the same checks and runner as the API; exit codes 0/2/1."""

from __future__ import annotations

import json
from pathlib import Path

from tests.conftest import run_plantsolve


def run(args: list[str], tmp_path: Path):
    return run_plantsolve(args, tmp_path, plugins=True, timeout=120)


def test_solve_success_writes_result_and_artifacts(tmp_path):
    (tmp_path / "in.json").write_text(json.dumps({"values": [6.0, 8.0]}))
    done = run(["solve", "test-compute", "in.json", "-o", "out.json"], tmp_path)
    assert done.returncode == 0, done.stderr
    assert json.loads((tmp_path / "out.json").read_text())["norm"] == 10.0
    assert (tmp_path / "out_artifacts" / "values.txt").read_text() == "6.0\n8.0"


def test_solve_upload_with_options(tmp_path):
    (tmp_path / "numbers.txt").write_text("1\n2\n")
    done = run(["solve", "test-compute", "numbers.txt", "--options", '{"seconds": 0}'], tmp_path)
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout)["total"] == 3.0


def test_solve_invalid_input_exits_2_with_the_problem(tmp_path):
    (tmp_path / "bad.json").write_text(json.dumps({"values": [1.0, 666.0]}))
    done = run(["solve", "test-compute", "bad.json", "-o", "out.json"], tmp_path)
    assert done.returncode == 2
    problem = json.loads(done.stderr[done.stderr.index("{"):])
    assert problem["status"] == 422 and problem["errors"][0]["loc"] == ["values", 1]
    assert not (tmp_path / "out.json").exists()
    assert run(["solve", "test-compute", "missing.json"], tmp_path).returncode == 2


def test_solve_failure_exits_1_with_the_report(tmp_path):
    (tmp_path / "in.json").write_text(json.dumps({"message": "diverged"}))
    done = run(["solve", "test-fail", "in.json", "-o", "out.json"], tmp_path)
    assert done.returncode == 1
    written = json.loads((tmp_path / "out.json").read_text())
    assert written["status"] == "failed" and written["report"]["stage"] == "fit"


def test_migrate_command(tmp_path):
    done = run(["migrate"], tmp_path)
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "var" / "plantsolve.db").exists()
