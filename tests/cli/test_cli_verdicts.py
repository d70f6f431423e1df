"""What ``plantsolve solve`` says happened: a result with a verdict against it (a failed inspection, a fit not
converged) exits 3 and says so, not 0 and 'succeeded'; the user's usual mistakes (a misspelt option or request
field, an output path that cannot be written, a file read in a unit nobody stated) are named before or after the
run instead of a traceback or silence."""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from plantsolve import cli
from plantsolve.schemas.common import VERDICT_CODES as VERDICTS
from plantsolve.solvers.kinds import KINDS, load_kinds
from tests.conftest import REPO

PLUGINS = "tests.support.kinds,tests.cli.verdict_kind"


def run(args: list[str], cwd: Path) -> subprocess.CompletedProcess:
    env = {"DATA_DIR": str(cwd / "var"), "PATH": "/usr/bin:/bin", "PLUGINS": PLUGINS, "PYTHONPATH": str(REPO)}
    return subprocess.run([str(Path(sys.executable).parent / "plantsolve"), *args], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=120)


def test_a_verdict_against_the_result_exits_3_and_is_named_last(tmp_path):
    (tmp_path / "fail.json").write_text(json.dumps({"codes": ["scan_gap", "inspection_failed", "not_converged"]}))
    done = run(["solve", "test-verdict", "fail.json", "-o", "out.json"], tmp_path)
    assert done.returncode == 3, done.stderr
    last = done.stderr.splitlines()[-1]
    assert "verdict is FAIL [inspection_failed]" in last and "exit code 3" in last and "succeeded" not in last
    assert "warning [not_converged]: the not_converged sentence" in done.stderr
    # the result and the artifacts are written as for any finished job
    assert [w["code"] for w in json.loads((tmp_path / "out.json").read_text())["report"]["warnings"]][1] == \
        "inspection_failed"
    assert (tmp_path / "out_artifacts" / "codes.txt").exists()
    (tmp_path / "caveat.json").write_text(json.dumps({"codes": ["scan_gap"]}))
    caveat = run(["solve", "test-verdict", "caveat.json", "-o", "caveat_out.json"], tmp_path)
    assert caveat.returncode == 0 and caveat.stderr.splitlines()[-1].endswith("succeeded with 1 warning(s) (above)")


@pytest.mark.parametrize("code", sorted(VERDICTS))
def test_every_verdict_exits_3(code, capsys):
    assert cli.finished_line("j", {"warnings": [{"code": code, "message": "m"}]}, 1) == cli.EXIT_VERDICT == 3
    assert f"verdict is {VERDICTS[code]} [{code}]" in capsys.readouterr().err
    assert cli.finished_line("j", {"warnings": [{"code": "rotation_rounded", "message": "m"}]}, 1) == 0


def test_every_verdict_code_is_one_a_solver_writes():
    """The table names codes the kinds emit: a renamed code would leave a failed inspection exiting 0 again."""
    source = "\n".join(p.read_text() for p in (REPO / "plantsolve" / "solvers").rglob("*.py"))
    for code in VERDICTS:
        assert re.search(rf'code=\s*"{code}"', source), code


def _refused(argv: list[str], capsys) -> str:
    args, extras = cli.build_parser(KINDS, describe_kinds=False).parse_known_args(argv)
    with pytest.raises(SystemExit) as stop:
        cli.refuse_unknown(args.command_parser, extras)
    assert stop.value.code == 2
    return capsys.readouterr().err


def test_a_misspelt_option_is_refused_naming_the_close_match(capsys):
    err = _refused(["solve", "tube", "scan.ply", "--optoins", "{}"], capsys)
    assert "unknown option --optoins; did you mean --options?" in err and err.startswith("usage: plantsolve solve")
    assert "unknown option --prot; did you mean --port?" in _refused(["serve", "--prot", "9"], capsys)
    assert "unexpected argument 'b.ply' (one INPUT per run)" in _refused(["solve", "tube", "a.ply", "b.ply"], capsys)
    assert "the options are --help, --output" in _refused(["solve", "tube", "a.ply", "--zzzzzzzzz"], capsys)


def test_a_misspelt_request_field_gets_the_close_match():
    spec = load_kinds(["tests.cli.verdict_kind"])["test-verdict"]
    problem = {"title": "Invalid input", "errors": [
        {"loc": ["cdoes"], "msg": "Extra inputs are not permitted", "type": "extra_forbidden"},
        {"loc": ["zzz"], "msg": "Extra inputs are not permitted", "type": "extra_forbidden"}]}
    lines = cli.problem_lines(problem, None, spec).splitlines()
    assert lines[1] == "  cdoes: Extra inputs are not permitted (did you mean 'codes'?)"
    assert lines[2] == "  zzz: Extra inputs are not permitted"
    # nested: a connection's 'form' is alignment's 'from' (the field's alias); an upload's option its kind's option
    nested = {"loc": ["connections", 0, "form"], "msg": "Extra inputs are not permitted", "type": "extra_forbidden"}
    assert cli.close_match(nested, KINDS["alignment"], upload=False) == " (did you mean 'from'?)"
    option = {"loc": ["options", "file_unit"], "msg": "Extra inputs are not permitted", "type": "extra_forbidden"}
    assert cli.close_match(option, KINDS["tube"], upload=True) == " (did you mean 'file_units'?)"


def _args(**given) -> argparse.Namespace:
    return argparse.Namespace(**{"output": None, "artifacts": None, "data_dir": None, "kind": "tube", **given})


def test_outputs_that_cannot_be_written_are_refused_before_the_run(tmp_path):
    (tmp_path / "a_file").write_text("")
    (tmp_path / "folder").mkdir()
    assert cli.output_problem(_args(output=str(tmp_path / "folder"))).endswith(
        f"is a folder: name the result file, e.g. -o {tmp_path / 'folder' / 'result.json'}")
    assert f"{tmp_path / 'a_file'} is a file, not a folder" in cli.output_problem(
        _args(output=str(tmp_path / "a_file" / "deeper" / "out.json")))
    assert cli.output_problem(_args(output=str(tmp_path / "a_file_artifacts.json"), artifacts=str(tmp_path / "a_file"))
                              ).startswith(f"--artifacts {tmp_path / 'a_file'}: ")
    assert cli.output_problem(_args(output=str(tmp_path / "new" / "out.json"))) is None  # folders are made


def test_a_folder_as_output_exits_2_before_solving(tmp_path):
    (tmp_path / "in.json").write_text(json.dumps({"codes": []}))
    (tmp_path / "out").mkdir()
    done = run(["solve", "test-verdict", "in.json", "-o", "out"], tmp_path)
    assert done.returncode == 2 and "Traceback" not in done.stderr
    assert done.stderr.startswith("plantsolve: -o out is a folder") and "job " not in done.stderr


def test_files_of_an_earlier_run_in_the_artifact_folder_are_named(tmp_path):
    (tmp_path / "in.json").write_text(json.dumps({"codes": []}))
    (tmp_path / "out_artifacts").mkdir()
    (tmp_path / "out_artifacts" / "inspection.png").write_bytes(b"an earlier run's plot")
    done = run(["solve", "test-verdict", "in.json", "-o", "out.json"], tmp_path)
    assert done.returncode == 0, done.stderr
    assert ("note: out_artifacts also holds 1 file(s) this run did not write (an earlier run's?): inspection.png"
            in done.stderr)


def test_a_file_read_in_the_default_unit_is_said():
    report = {"details": {"source": {"units": {"file_unit": "mm", "request_unit": "mm", "basis": "request"}}}}
    note = cli.assumed_unit_note(report, "scan.ply", None, KINDS["tube"])
    assert note == ("note: scan.ply states no unit: its numbers were read as mm, the request's default 'units'; "
                    "if they are in another unit, say so: --options '{\"file_units\": \"m\"}'")
    assert cli.assumed_unit_note(report, "scan.ply", {"units": "mm"}, KINDS["tube"]) is None  # the user said it
    stated = {"details": {"source": {"units": {"file_unit": "m", "request_unit": "mm", "basis": "header"}}}}
    assert cli.assumed_unit_note(stated, "scan.csv", None, KINDS["tube"]) is None
    metres = {"details": {"source": {"units": {"file_unit": "m", "request_unit": "m", "basis": "request"}}}}
    assert "--options '{\"file_units\": \"mm\"}'" in cli.assumed_unit_note(metres, "a.obj", None, KINDS["polyhedra"])


def test_solve_help_states_the_units_and_the_exit_codes():
    solve = next(a for a in cli.build_parser(KINDS)._actions if isinstance(a, argparse._SubParsersAction))
    helped = solve.choices["solve"].format_help()
    assert "3 a result written whose report holds a verdict against it" in " ".join(helped.split())
    assert "by default alignment mm, flowmeter mm, polyhedra m, rigidity mm, tube mm" in " ".join(helped.split())


def test_a_folder_as_input_a_file_as_data_dir_and_a_store_that_cannot_open_exit_2_in_a_line(tmp_path):
    (tmp_path / "in.json").write_text(json.dumps({"codes": []}))
    (tmp_path / "a_file").write_text("")
    for args, expected in (
            (["tests"], "plantsolve: tests is a folder, not a file"),
            (["in.json", "--data-dir", "a_file"], "plantsolve: --data-dir a_file: a_file is a file, not a folder"),
            (["in.json", "--store", "postgres://me:secret@nohost/db"],
             "plantsolve: --store postgres://me:***@nohost/db: the database cannot be opened: Can't load plugin: "
             "sqlalchemy.dialects:postgres")):
        (tmp_path / "tests").mkdir(exist_ok=True)
        done = run(["solve", "test-verdict", *args], tmp_path)
        assert done.returncode == 2 and done.stderr.strip() == expected, done.stderr


def test_a_file_of_another_kind_is_refused_naming_the_kinds_that_read_it(tmp_path):
    (tmp_path / "my numbers.txt").write_text("1\n2\n")
    done = run(["solve", "test-verdict", "my numbers.txt"], tmp_path)
    assert done.returncode == 2, done.stderr
    assert done.stderr.splitlines()[-1] == \
        "  .txt files are read by test-compute, tube: plantsolve solve test-compute 'my numbers.txt'"


def test_a_request_without_units_is_said_to_be_read_in_the_default():
    note = cli.unstated_units_note(b'{"faces": []}', "house.json", KINDS["polyhedra"])
    assert note == ("note: house.json states no 'units': its numbers were read as m, the default; if they are in "
                    "another unit, add \"units\" to the request")
    assert cli.unstated_units_note(b'{"faces": [], "units": "mm"}', "house.json", KINDS["polyhedra"]) is None
    assert cli.unstated_units_note(b'{"points": []}', "map.json", KINDS["perfmap"]) is None  # no default to take


def test_a_result_sent_to_dev_null_puts_no_artifact_folder_into_dev(monkeypatch):
    args = _args(output="/dev/null")
    # as for a user who is not root: /dev/null is writable, /dev is not
    real_access = os.access
    monkeypatch.setattr(cli.os, "access", lambda path, mode: str(path) != "/dev" and real_access(path, mode))
    assert cli.output_problem(args) is None
    folder = cli._artifact_folder(args)
    try:
        assert folder.parent != Path("/dev") and folder.name.startswith("plantsolve-tube-artifacts-")
    finally:
        folder.rmdir()


def test_artifacts_into_the_folder_of_the_input_and_the_result_name_neither_as_an_earlier_runs(tmp_path):
    (tmp_path / "in.json").write_text(json.dumps({"codes": []}))
    done = run(["solve", "test-verdict", "in.json", "-o", "out.json", "--artifacts", "."], tmp_path)
    assert done.returncode == 0 and "note:" not in done.stderr, done.stderr
    assert (tmp_path / "codes.txt").exists()
