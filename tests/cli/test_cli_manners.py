"""How the command line talks: --version, kinds as choices with help, help and a default on every option,
one line per bad field (the document with --json), a bad --options named as such, a progress bar on standard
error, and a busy port refused before any start-up work."""

from __future__ import annotations

import argparse
import json
import re
import socket
from importlib.metadata import version
from pathlib import Path

import pytest

from plantsolve import cli
from plantsolve.solvers.kinds import KINDS
from tests.conftest import run_plantsolve


def run(args: list[str], tmp_path: Path, timeout: float = 120):
    return run_plantsolve(args, tmp_path, plugins=True, timeout=timeout)


def test_version(tmp_path):
    done = run(["--version"], tmp_path)
    assert done.returncode == 0 and done.stdout.strip() == f"plantsolve {version('plantsolve')}"


def test_kinds_are_choices_with_help(tmp_path):
    helped = run(["solve", "--help"], tmp_path)
    assert helped.returncode == 0
    for kind, spec in KINDS.items():  # each kind on a line of its own, with the files it reads
        line = next(ln for ln in helped.stdout.splitlines() if ln.strip().startswith(kind + " "))
        assert all(ext in line for ext in spec.upload_extensions), line
    wrong = run(["solve", "tubes", "in.json"], tmp_path)
    assert wrong.returncode == 2 and "invalid choice: 'tubes'" in wrong.stderr and "'tube'" in wrong.stderr


def _options(parser: argparse.ArgumentParser):
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield from ((name, a) for a in sub._actions if a.option_strings and a.dest != "help")


def test_every_option_has_help_and_its_default():
    parser = cli.build_parser(KINDS)
    options = list(_options(parser))
    assert {(name, a.dest) for name, a in options} >= {("serve", "host"), ("serve", "port"), ("serve", "log_level"),
                                                     ("worker", "concurrency"), ("solve", "options")}
    formatter = cli.HelpFormatter("plantsolve")
    for name, action in options:
        text = formatter._get_help_string(action) or ""
        assert action.help and "default" in text, (name, action.dest, text)
    serve_help = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction)).choices["serve"]
    assert "(default: 8000)" in serve_help.format_help() and "(default: 127.0.0.1)" in serve_help.format_help()


def test_invalid_input_is_one_line_per_field_and_the_document_with_json(tmp_path):
    (tmp_path / "bad.json").write_text(json.dumps({"values": [666.0, 1.0, 666.0]}))
    done = run(["solve", "test-compute", "bad.json"], tmp_path)
    assert done.returncode == 2 and "{" not in done.stderr
    lines = done.stderr.splitlines()
    assert lines[0] == "plantsolve: Invalid input (2 fields):"
    assert lines[1:3] == ["  values[0]: must not be 666 (test rule)", "  values[2]: must not be 666 (test rule)"]
    assert len(lines) == 4  # and where the whole document is
    full = run(["solve", "test-compute", "bad.json", "--json"], tmp_path)
    assert full.returncode == 2
    assert [e["loc"] for e in json.loads(full.stderr)["errors"]] == [["values", 0], ["values", 2]]


def test_a_bad_options_is_named_as_such(tmp_path):
    (tmp_path / "numbers.txt").write_text("1\n2\n")
    for options, expected in (("{seconds: 1}", "plantsolve: --options is not valid JSON: Expecting property name"),
                              ("[1]", "plantsolve: --options must be a JSON object"),
                              ('{"seconds": -1}', "  --options seconds: Input should be greater than or equal to 0")):
        done = run(["solve", "test-compute", "numbers.txt", "--options", options], tmp_path)
        assert done.returncode == 2, done.stderr
        assert expected in done.stderr.splitlines()[0 if expected.startswith("plantsolve") else 1], done.stderr
        assert "form field" not in done.stderr


def test_a_failure_is_a_few_lines_and_the_report_with_json(tmp_path):
    (tmp_path / "in.json").write_text(json.dumps({"message": "diverged"}))
    done = run(["solve", "test-fail", "in.json"], tmp_path)
    assert done.returncode == 1 and "{" not in done.stderr
    assert "failed at stage 'fit': diverged" in done.stderr
    full = run(["solve", "test-fail", "in.json", "--json"], tmp_path)
    report = json.loads(full.stderr[full.stderr.index("{"):full.stderr.rindex("}") + 1])
    assert full.returncode == 1 and report["report"]["stage"] == "fit"


def test_solve_shows_a_progress_bar_on_standard_error(tmp_path):
    (tmp_path / "in.json").write_text(json.dumps({"values": [3.0, 4.0], "seconds": 2.0}))
    done = run(["solve", "test-compute", "in.json", "--progress"], tmp_path)
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout)["norm"] == 5.0  # the bar stays off standard output
    percents = [int(p) for p in re.findall(r"(\d+)%", done.stderr)]
    assert percents == sorted(percents) and percents[-1] == 100 and len(set(percents)) >= 5, percents
    # the solver's own progress messages (the bar samples the job's row: which steps it shows varies with load)
    assert re.search(r"step \d+ of 20", done.stderr), done.stderr
    quiet = run(["solve", "test-compute", "in.json"], tmp_path)  # standard error is no terminal: no bar
    assert quiet.returncode == 0 and "%" not in quiet.stderr


def test_a_busy_port_fails_at_once_before_any_start_up_work(tmp_path):
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        done = run(["serve", "--port", str(port)], tmp_path, timeout=60)
    assert done.returncode == 2
    assert done.stderr.splitlines() == [done.stderr.strip()] and f"127.0.0.1:{port}" in done.stderr, done.stderr
    assert "Address already in use" in done.stderr
    assert not (tmp_path / "var").exists()  # no database made, no migration run, no job process started


def test_serve_runs_on_the_socket_it_bound(tmp_path, monkeypatch, serve_in_this_process):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("DATA_DIR", str(tmp_path / "var"))
    monkeypatch.setenv("EMBEDDED_MODE", "thread")
    served = []
    monkeypatch.setattr(cli, "serve_on", lambda app, sock, args: served.append(sock.getsockname()))
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    assert cli.cmd_serve(argparse.Namespace(host="127.0.0.1", port=port, log_level="warning")) == 0
    assert served == [("127.0.0.1", port)]
    with socket.socket() as again:  # closed afterwards: the port is free again
        again.bind(("127.0.0.1", port))


@pytest.mark.parametrize("loc,expected", [(["values", 1], "values[1]"), (["options", "grid", 0], "options.grid[0]"),
                                          ([], "(input)")])
def test_field_paths(loc, expected):
    assert cli.field_path(loc) == expected


@pytest.mark.parametrize("flag,env,expected", [("warning", None, "warning"), (None, "error", "error"),
                                               ("debug", "error", "debug"), (None, None, "info")])
def test_serve_log_level_reaches_the_plantsolve_loggers_and_the_job_processes(tmp_path, monkeypatch, flag, env,
                                                                               expected, serve_in_this_process):
    import logging

    from plantsolve.app.settings import get_settings

    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("DATA_DIR", str(tmp_path / "var"))
    monkeypatch.setenv("EMBEDDED_MODE", "thread")
    if env:
        monkeypatch.setenv("LOG_LEVEL", env)
    else:
        monkeypatch.delenv("LOG_LEVEL", raising=False)
    get_settings.cache_clear()
    logger = logging.getLogger("plantsolve")
    monkeypatch.setattr(logger, "level", logger.level)  # restored afterwards for the other tests
    seen = []
    monkeypatch.setattr(cli, "serve_on", lambda app, sock, args: seen.append(
        (app.state.settings.log_level, args.log_level, logger.getEffectiveLevel())))
    try:
        assert cli.cmd_serve(argparse.Namespace(host="127.0.0.1", port=0, log_level=flag)) == 0
    finally:
        get_settings.cache_clear()
    # uvicorn gets the level name; the job processes are started with app.state.settings
    assert seen == [(expected, expected, getattr(logging, expected.upper()))]
