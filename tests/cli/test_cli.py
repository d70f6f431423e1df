"""``plantsolve`` CLI: solve runs the same checks and runner as the API; exit codes 0/2/1."""

from __future__ import annotations

import json
import shutil
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
    done = run(["solve", "test-compute", "bad.json", "-o", "out.json", "--json"], tmp_path)
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


def _files(folder: Path) -> set[str]:
    return {str(p.relative_to(folder)) for p in folder.rglob("*")}


def test_solve_writes_nothing_unasked_into_the_current_directory(tmp_path):
    (tmp_path / "in.json").write_text(json.dumps({"values": [6.0, 8.0]}))
    done = run(["solve", "test-compute", "in.json"], tmp_path)
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout)["norm"] == 10.0
    assert _files(tmp_path) == {"in.json"}  # no var/, no database, no artifacts here
    line = next(ln for ln in done.stderr.splitlines() if ln.startswith("artifacts: "))
    folder = Path(line.rsplit(" in ", 1)[1])
    try:
        assert (folder / "values.txt").read_text() == "6.0\n8.0" and not folder.is_relative_to(tmp_path)
    finally:
        shutil.rmtree(folder)


def test_solve_artifacts_go_where_asked(tmp_path):
    (tmp_path / "in.json").write_text(json.dumps({"values": [3.0, 4.0]}))
    done = run(["solve", "test-compute", "in.json", "-o", "res/out.json", "--artifacts", "plots"], tmp_path)
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "plots" / "values.txt").read_text() == "3.0\n4.0"
    assert f"in {Path('plots')}" in done.stderr and not (tmp_path / "res" / "out_artifacts").exists()


def test_warnings_are_printed_with_their_codes(tmp_path):
    (tmp_path / "in.json").write_text(json.dumps({"values": [-3.0, 4.0]}))
    done = run(["solve", "test-compute", "in.json", "-o", "out.json"], tmp_path)
    assert done.returncode == 0, done.stderr
    assert "warning [negative]: Some values are negative." in done.stderr
    assert "succeeded with 1 warning(s)" in done.stderr
    assert json.loads((tmp_path / "out.json").read_text())["norm"] == 5.0


def test_cli_runs_stay_out_of_the_servers_database_unless_named(tmp_path):
    """By default a CLI run has a store of its own; --data-dir (or --store) records it where the server
    keeps its jobs, so that it shows there."""
    import sqlite3

    (tmp_path / "in.json").write_text(json.dumps({"values": [1.0, 2.0]}))
    assert run(["migrate"], tmp_path).returncode == 0  # the server's database, at DATA_DIR=var
    db = tmp_path / "var" / "plantsolve.db"

    def jobs() -> int:
        with sqlite3.connect(db) as con:
            return con.execute("select count(*) from jobs").fetchone()[0]

    assert run(["solve", "test-compute", "in.json", "-o", "a.json"], tmp_path).returncode == 0
    assert jobs() == 0
    done = run(["solve", "test-compute", "in.json", "-o", "b.json", "--data-dir", "var"], tmp_path)
    assert done.returncode == 0, done.stderr
    assert jobs() == 1
    done = run(["solve", "test-compute", "in.json", "-o", "c.json", "--store", f"sqlite:///{db}"], tmp_path)
    assert done.returncode == 0, done.stderr
    assert jobs() == 2


def test_a_perfmap_run_prints_each_of_its_warnings_with_its_code(tmp_path):
    """The issue's case: the N+3 map succeeds with warnings, and standard error lists every one; the --options
    given reach the solver (the map on the grid asked for) and every artifact is written beside the result."""
    examples = Path(__file__).resolve().parents[2] / "examples" / "perfmap"
    done = run_plantsolve(["solve", "perfmap", str(examples / "n3_fan_map.csv"), "-o", "map.json",
                           "--options", '{"grid": [16, 16]}'], tmp_path, timeout=300)
    assert done.returncode == 0, done.stderr
    result = json.loads((tmp_path / "map.json").read_text())
    assert len(result["map"]["flow"]) == 16 and len(result["map"]["pressure"]) == 16
    warnings = result["report"]["warnings"]
    printed = [ln for ln in done.stderr.splitlines() if ln.startswith("warning [")]
    assert warnings and len(printed) == len(warnings)
    assert [ln.split("]")[0][len("warning ["):] for ln in printed] == [w["code"] for w in warnings]
    assert f"with {len(warnings)} warning(s)" in done.stderr
    assert sorted(p.name for p in (tmp_path / "map_artifacts").iterdir()) == sorted(
        ["characteristics.png", "characteristics.svg", "envelopes.png", "envelopes.svg", "map.png", "map.svg",
         "curves.csv", "map.csv", "map_beta.csv", "map_gasturb_theta0.map", "map_gasturb_theta5.map",
         "map_pycycle.py"])


def test_serve_warns_at_start_when_open_without_keys(tmp_path, monkeypatch, caplog, serve_in_this_process):
    """`plantsolve serve --host 0.0.0.0` without API_KEYS says so before the first request arrives."""
    import argparse

    from plantsolve import cli

    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("API_KEYS", raising=False)
    monkeypatch.setenv("DATA_DIR", str(tmp_path / "var"))
    monkeypatch.setenv("EMBEDDED_MODE", "thread")
    started = []
    monkeypatch.setattr(cli, "serve_on", lambda app, sock, args: started.append(args.host))
    for host, warned in (("0.0.0.0", True), ("127.0.0.1", False)):
        caplog.clear()
        assert cli.cmd_serve(argparse.Namespace(host=host, port=0, log_level="warning")) == 0
        assert ("API_KEYS is empty" in caplog.text) is warned
    assert started == ["0.0.0.0", "127.0.0.1"]


def test_a_request_file_with_a_utf8_mark_is_read_as_its_text(tmp_path):
    (tmp_path / "in.json").write_bytes(b"\xef\xbb\xbf" + json.dumps({"values": [6.0, 8.0]}).encode())
    done = run(["solve", "test-compute", "in.json"], tmp_path)
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout)["norm"] == 10.0
