"""``plantsolve`` command line: serve, worker, solve, migrate.

``plantsolve solve KIND INPUT [-o OUT]`` runs one job through the same submission checks and
the same runner as the service, in a store of its own (not the server's database, unless ``--store`` or
``--data-dir`` names it); the result goes to OUT or standard output, artifacts to ``--artifacts DIR``
(default next to OUT, or a temporary folder), warnings with their codes to standard error. Exit
codes: 0 success; 3 a result written whose report holds a verdict against it (a failed or undetermined
inspection, a fit not converged, a verification failed, a tolerance not reached: the last line names it); 2
invalid input (one line per bad field; ``--json`` prints the problem document), or a command line, an output path
or a store refused before the run; 1 solver failure (the report is written). A progress bar goes to standard error
while the job runs (on a terminal, or with ``--progress``).
"""

from __future__ import annotations

import argparse
import codecs
import ctypes
import gc
import json
import logging
import os
import shlex
import socket
import sys
import tempfile
import textwrap
import threading
import uuid
from pathlib import Path
from typing import Any, Mapping


def _settings():
    from plantsolve.app.settings import get_settings

    return get_settings()


def _fresh_settings():
    """The settings read again from the environment (after this process changed it)."""
    from plantsolve.app.settings import get_settings
    from plantsolve.jobs.settings import get_job_settings

    get_settings.cache_clear()
    get_job_settings.cache_clear()
    return get_settings()


def bind(host: str, port: int) -> socket.socket:
    """The listening address, bound now (as uvicorn would bind it), so that a busy port fails before any start-up
    work; uvicorn then serves on this very socket, so nothing can take the port in between."""
    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    sock = socket.socket(family, socket.SOCK_STREAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    try:
        sock.bind((host, port))
    except BaseException:
        sock.close()
        raise
    return sock


def cmd_serve(args: argparse.Namespace) -> int:
    try:
        sock = bind(args.host, args.port)
    except OSError as error:  # before migrations run and job processes start: nothing to undo
        reason = error.strerror or str(error)
        print(f"plantsolve serve: cannot listen on {args.host}:{args.port}: {reason} (another server on this port? "
              "choose another with --port)", file=sys.stderr)
        return 2
    try:
        from plantsolve.app.auth import warn_if_exposed
        from plantsolve.app.main import create_app

        settings = _settings()
        if args.log_level:  # the flag wins over LOG_LEVEL, here and in the job processes (they get these settings)
            settings = settings.model_copy(update={"log_level": args.log_level})
        args.log_level = settings.log_level
        app = create_app(settings)
        warn_if_exposed(args.host, app.state.keys)
        # Everything imported so far (FastAPI, SQLAlchemy, every kind's schemas) lives as long as the process: out of
        # the collector's sight, a full collection no longer walks it and stalls requests for tens of ms.
        gc.collect()
        gc.freeze()
        serve_on(app, sock, args)
    finally:
        sock.close()
    return 0


# a job that succeeded but whose report holds a verdict against its result (schemas.common.VERDICT_CODES)
EXIT_VERDICT = 3
SHUTDOWN_SECONDS = 5
LOG_LEVELS = ["critical", "error", "warning", "info", "debug"]


def server_config(app, args: argparse.Namespace):
    """uvicorn's configuration for ``app``: X-Forwarded-For/-Proto are believed only from the addresses in
    ``FORWARDED_ALLOW_IPS`` (uvicorn's own default trusts loopback: any local process, or a local proxy passing
    the header on, would choose the client address the login limit counts); no ``server: uvicorn`` banner."""
    import uvicorn

    proxies = app.state.settings.forwarded_allow_ips
    # SIGTERM: open requests get SHUTDOWN_SECONDS to finish, then the lifespan stops the job processes
    # (running jobs are handed back to the queue; see workers/processes.py)
    return uvicorn.Config(app, host=args.host, port=args.port, log_level=args.log_level,
                          timeout_graceful_shutdown=SHUTDOWN_SECONDS, server_header=False,
                          proxy_headers=bool(proxies), forwarded_allow_ips=",".join(proxies) or None)


def serve_on(app, sock: socket.socket, args: argparse.Namespace) -> None:
    """uvicorn on the socket bound by :func:`bind` (what ``uvicorn.run`` does, minus the binding)."""
    import uvicorn

    class Server(uvicorn.Server):
        async def startup(self, sockets: list[socket.socket] | None = None) -> None:
            await super().startup(sockets)
            if self.started:  # uvicorn names the address only for sockets it bound itself
                host, port = sock.getsockname()[:2]
                logging.getLogger("uvicorn.error").info(
                    "Uvicorn running on http://%s:%d (Press CTRL+C to quit)", f"[{host}]" if ":" in host else host, port)

    server = Server(server_config(app, args))
    try:
        server.run(sockets=[sock])
    except KeyboardInterrupt:
        pass


def cmd_worker(args: argparse.Namespace) -> int:
    settings = _settings()
    if not settings.broker_url:
        print("plantsolve worker needs BROKER_URL (e.g. redis://127.0.0.1:6379/0); "
              "without it jobs run inside 'plantsolve serve'.", file=sys.stderr)
        return 2
    from plantsolve.workers.celery_app import create_celery

    if args.log_level:  # the flag wins over LOG_LEVEL, in Celery's and in plantsolve's loggers of every process
        os.environ["LOG_LEVEL"] = args.log_level
        settings = _fresh_settings()
    celery_app = create_celery(settings)
    argv = ["worker", f"--loglevel={settings.log_level.upper()}", f"--concurrency={args.concurrency}", "--pool=prefork"]
    if args.hostname:
        argv.append(f"--hostname={args.hostname}")
    celery_app.worker_main(argv)
    return 0


def cmd_migrate(args: argparse.Namespace) -> int:
    from plantsolve.store import Store

    settings = _settings()
    Store.open(settings, migrate=True).close()
    print(f"database at {settings.resolved_database_url} is at the newest revision")
    return 0


class _InlineDispatcher:
    """Collects enqueued ids so ``solve`` runs them in this process."""

    def __init__(self) -> None:
        self.pending: list[uuid.UUID] = []

    def enqueue(self, job_id: uuid.UUID, kind: str = "") -> None:
        self.pending.append(job_id)

    def ping(self) -> None: ...

    def start(self) -> None: ...

    def stop(self) -> None: ...


def _solve_settings(args: argparse.Namespace, scratch: Path):
    """The settings of a CLI run: its own store in ``scratch`` (a temporary folder removed afterwards), so
    that CLI runs neither land in the server's database nor on its dashboard, unless ``--store`` or
    ``--data-dir`` names a database to use (the server's, to see the job there)."""
    settings = _settings()
    # the bar reads the job row: progress is written at least 10 times a second (not the service's 2)
    settings = settings.model_copy(update={"progress_write_seconds": min(settings.progress_write_seconds, 0.1)})
    if args.store or args.data_dir:
        updates: dict = {}
        if args.data_dir:
            updates["data_dir"] = Path(args.data_dir)
        if args.store:
            updates["database_url"] = args.store
        return settings.model_copy(update=updates)
    return settings.model_copy(update={"data_dir": scratch, "database_url": None, "artifact_dir": None})


def _beside_output(args: argparse.Namespace) -> bool:
    """Whether ``-o OUT`` names a file the artifacts' folder goes beside: not a device or a pipe (``-o /dev/null``
    discards the result; its artifacts do not belong in ``/dev``)."""
    out = Path(args.output) if args.output else None
    return out is not None and (not out.exists() or out.is_file() or out.is_dir())


def _artifact_folder(args: argparse.Namespace) -> Path:
    """``--artifacts``, else ``<OUT stem>_artifacts`` next to ``-o OUT``, else a new temporary folder (the
    result went to standard output or a device: nothing is written into the current directory unasked)."""
    if args.artifacts:
        return Path(args.artifacts)
    if _beside_output(args):
        out = Path(args.output)
        return out.with_name(out.stem + "_artifacts")
    return Path(tempfile.mkdtemp(prefix=f"plantsolve-{args.kind}-artifacts-"))


def _print_warnings(report: dict | None) -> int:
    warnings = (report or {}).get("warnings") or []
    for w in warnings:
        print(f"warning [{w.get('code', '?')}]: {w.get('message', '')}", file=sys.stderr)
    return len(warnings)


def cmd_solve(args: argparse.Namespace) -> int:
    path = Path(args.input)
    if not path.is_file():
        print(f"plantsolve: {path} is a folder, not a file" if path.is_dir() else f"plantsolve: no such file: {path}",
              file=sys.stderr)
        return 2
    if args.options is not None:
        try:
            options = json.loads(args.options)
        except json.JSONDecodeError as error:
            print(f"plantsolve: --options is not valid JSON: {error.msg} (column {error.colno})", file=sys.stderr)
            return 2
        if not isinstance(options, dict):
            print(f"plantsolve: --options must be a JSON object, e.g. '{{\"units\": \"m\"}}', not "
                  f"{type(options).__name__}", file=sys.stderr)
            return 2
    refused = output_problem(args)
    if refused:  # said before the run: a solve of minutes is not lost to a result it cannot write
        print(f"plantsolve: {refused}", file=sys.stderr)
        return 2
    with tempfile.TemporaryDirectory(prefix="plantsolve-cli-") as scratch:
        return _solve(args, path, _solve_settings(args, Path(scratch)))


def _shown_url(url: str) -> str:
    """A database URL as it may be printed: its password as ***."""
    from sqlalchemy.engine import make_url
    from sqlalchemy.exc import ArgumentError

    try:
        return make_url(url).render_as_string(hide_password=True)
    except ArgumentError:
        return url


def _first_line(error: BaseException) -> str:
    """An error's own sentence, without the SQL and the link to the docs SQLAlchemy appends."""
    text = str(getattr(error, "orig", None) or error).strip()
    return text.splitlines()[0] if text else type(error).__name__


def _unwritable(folder: Path) -> str | None:
    """Why files cannot be written into ``folder`` (made when missing), or ``None``."""
    probe = folder
    while not probe.exists() and probe != probe.parent:  # the missing folders are made in the nearest that exists
        probe = probe.parent
    if not probe.is_dir():
        return f"{probe} is a file, not a folder"
    if not os.access(probe, os.W_OK | os.X_OK):
        return f"{probe} is not writable"
    return None


def output_problem(args: argparse.Namespace) -> str | None:
    """Why ``-o`` or the artifact folder cannot be written, or ``None``."""
    if args.output:
        out = Path(args.output)
        if out.is_dir():
            return f"-o {out} is a folder: name the result file, e.g. -o {out / 'result.json'}"
        # the result is written in place: a file that exists needs only its own write access (/dev/null for
        # anyone), a new one the folder's
        why = ((f"{out} is not writable" if not os.access(out, os.W_OK) else None) if out.exists()
               else _unwritable(out.parent))
        if why:
            return f"-o {out}: {why}"
    if args.data_dir:
        data = Path(args.data_dir)
        why = f"{data} is a file, not a folder" if data.is_file() else _unwritable(data)
        if why:
            return f"--data-dir {data}: {why}"
    if args.artifacts or _beside_output(args):
        folder = _artifact_folder(args)
        why = f"{folder} is a file, not a folder" if folder.is_file() else _unwritable(folder)
        if why:
            return f"{'--artifacts' if args.artifacts else 'the artifact folder'} {folder}: {why}" + (
                "" if args.artifacts else " (name another with --artifacts DIR)")
    return None


# what a run of one job calls of its kind (and, for a file, its reader): imported before the job, see below
SOLVE_ROLES = ("check_input", "load", "solve", "render_artifacts")


def _collect_from_now_on() -> None:
    """The modules imported so far (the store's, the kind's, matplotlib) live as long as the process: the
    collector, off since :func:`main` began, comes back for what the job makes, with them out of its sight (a
    collection among imports walked them again and again: a sixth of a small job's CPU seconds)."""
    gc.freeze()
    gc.enable()


def _solve(args: argparse.Namespace, path: Path, settings) -> int:
    from sqlalchemy.exc import SQLAlchemyError

    from plantsolve.jobs.context import ServiceContext, worker_name
    from plantsolve.jobs.errors import ProblemError
    from plantsolve.jobs.lifecycle import SUCCEEDED
    from plantsolve.jobs.runner import run_job
    from plantsolve.jobs.service import JobService

    # a temporary store of this run alone gets its tables at once; a named one (--store, --data-dir) is migrated
    try:
        ctx = ServiceContext.create(settings, migrate=True if args.store or args.data_dir else "scratch")
    except (SQLAlchemyError, OSError) as error:  # a URL of no database there is, a folder that is a file
        named = f"--store {_shown_url(args.store)}" if args.store else f"--data-dir {args.data_dir}" if args.data_dir \
            else "the store"
        print(f"plantsolve: {named}: the database cannot be opened: {_first_line(error)}", file=sys.stderr)
        return 2
    try:
        upload = not (path.suffix.lower() == ".json" and args.options is None)
        ctx.kinds[args.kind].preload(SOLVE_ROLES + (("parse_upload",) if upload else ()))
        _collect_from_now_on()
        # the upload is read in a bounded process forked from this one (one thread, the kind's reader imported
        # above); a JSON request is read here, in this process
        dispatcher = _InlineDispatcher()
        service = JobService(ctx, dispatcher, readers=[], reader_start="fork")
        content = path.read_bytes()
        if not upload:
            # a request file saved by an editor that marks UTF-8 (Windows' Notepad): the mark is the file's
            # encoding, not the request's text (RFC 8259 lets a parser ignore it); over HTTP a body stays as sent
            content = content.removeprefix(codecs.BOM_UTF8)
        try:
            if not upload:
                submitted = service.submit_json(args.kind, content, None)
            else:
                submitted = service.submit_upload(args.kind, path.name, content, args.options, None)
                content = b""  # stored: its bytes are not kept through the job (a 48 MB STL beside the solve's peak)
        except ProblemError as error:
            problem = error.to_problem().model_dump(mode="json", exclude_none=True)
            if args.json:
                print(json.dumps(problem, indent=2), file=sys.stderr)
            else:
                print(problem_lines(problem, options_of(args), ctx.kinds[args.kind], upload), file=sys.stderr)
                readers = other_readers(ctx.kinds, path.suffix.lower(), args.kind) if problem.get("status") == 415 \
                    else []
                if readers:  # refused already: every kind's spec is read only now
                    print(f"  {path.suffix.lower()} files are read by {', '.join(readers)}: plantsolve solve "
                          f"{readers[0]} {shlex.quote(str(path))}", file=sys.stderr)
            return 2
        job_id = submitted.job.id
        name = worker_name("cli")
        with JobProgressBar(service, job_id, args.kind, enabled=_wants_progress(args)):
            while dispatcher.pending:
                run_job(ctx, dispatcher.pending.pop(0), worker=name, requeue=dispatcher.enqueue)
        job = service.get(job_id)
        if job.status == SUCCEEDED:
            _write(args.output, job.result)
            artifacts = service.view(job).artifacts
            if artifacts:
                folder = _artifact_folder(args)
                folder.mkdir(parents=True, exist_ok=True)
                for artifact in artifacts:  # copied from the store in chunks: a 180 MB table is never in memory
                    with open(folder / artifact.name, "wb") as out:
                        out.writelines(service.artifact(job_id, artifact.name)[1].chunks())
                print(f"artifacts: {', '.join(a.name for a in artifacts)} in {folder}", file=sys.stderr)
                ours = {a.name for a in artifacts} | {Path(f).resolve() for f in (args.input, args.output) if f}
                others = sorted(p.name for p in folder.iterdir() if p.name not in ours and p.resolve() not in ours)
                if others:  # an earlier run's inspection plot beside this run's files would be read as this run's
                    print(f"note: {folder} also holds {len(others)} file(s) this run did not write (an earlier "
                          f"run's?): {', '.join(others[:8])}{', ...' if len(others) > 8 else ''}", file=sys.stderr)
            report = job.report or (job.result or {}).get("report")
            n = _print_warnings(report)
            note = (assumed_unit_note(report, path.name, options_of(args), ctx.kinds[args.kind]) if upload
                    else unstated_units_note(content, path.name, ctx.kinds[args.kind]))
            if note:
                print(note, file=sys.stderr)
            return finished_line(str(job_id), report, n)
        failure = {"job": str(job_id), "status": job.status, "report": job.report}
        if args.output or args.json:
            _write(args.output, failure, stream=sys.stderr)
        _print_warnings(job.report)
        print(failure_lines(str(job_id), job.status, job.report, args.output), file=sys.stderr)
        return 1
    finally:
        ctx.close()


def other_readers(kinds: Mapping[str, Any], suffix: str, kind: str) -> list[str]:
    """The kinds other than ``kind`` that read files ending in ``suffix``."""
    return sorted(k for k in kinds if k != kind and suffix in kinds[k].upload_extensions)


def options_of(args: argparse.Namespace) -> dict | None:
    return json.loads(args.options) if args.options else None


def finished_line(job_id: str, report: dict | None, warnings: int) -> int:
    """The run's last line and exit code: 0 when the result stands, 3 when a warning of the report is a verdict
    against it (a failed inspection, a fit not converged: the result and artifacts are written all the same)."""
    from plantsolve.app.verdicts import report_warnings
    from plantsolve.schemas.common import verdicts_of

    found = verdicts_of(report_warnings(report))
    counted = f" with {warnings} warning(s) (above)" if warnings else ""
    if not found:
        print(f"job {job_id} succeeded{counted}", file=sys.stderr)
        return 0
    head = found[0]
    print(f"job {job_id} finished{counted}, but the verdict is {head.label} [{head.code}]: the result does not pass "
          f"(exit code {EXIT_VERDICT})", file=sys.stderr)
    return EXIT_VERDICT


def assumed_unit_note(report: dict | None, filename: str, options: dict | None, spec) -> str | None:
    """A line when an uploaded file stated no unit and ``--options`` named none either, so its numbers were read in
    the request's default unit (``report.details.source.units.basis == "request"``, as the kinds that read such
    files record it): a file in metres read as millimetres is a thousand times off without any warning."""
    source = ((report or {}).get("details") or {}).get("source")
    units = source.get("units") if isinstance(source, dict) else None
    if not isinstance(units, dict) or units.get("basis") != "request" or not units.get("request_unit"):
        return None
    from plantsolve.app.dashboard_views import options_model

    option = "file_units" if "file_units" in options_model(spec).model_fields else "units"
    if options and (option in options or "units" in options):
        return None
    example = json.dumps({option: "mm" if units["request_unit"] == "m" else "m"})
    return (f"note: {filename} states no unit: its numbers were read as {units['request_unit']}, the request's "
            f"default 'units'; if they are in another unit, say so: --options '{example}'")


def unstated_units_note(content: bytes, filename: str, spec) -> str | None:
    """A line when a JSON request states no ``units`` and the kind's default was taken. The text is searched, not
    parsed again (a request of many megabytes): a key ``"units"`` anywhere counts as stated, so the line is never
    said wrongly, only now and then left out."""
    field = spec.request_model.model_fields.get("units")
    if field is None or not isinstance(field.default, str) or b'"units"' in content:
        return None
    return (f"note: {filename} states no 'units': its numbers were read as {field.default}, the default; "
            f"if they are in another unit, add \"units\" to the request")


def field_path(loc: list) -> str:
    """A field's place as one writes it: ``values[1]``, ``options.grid``, ``file.row[12]``."""
    text = ""
    for part in loc:
        text += f"[{part}]" if isinstance(part, int) else (f".{part}" if text else str(part))
    return text or "(input)"


def _model_in(annotation: Any):
    """The pydantic model an annotation holds (``Model``, ``Model | None``, ``list[Model]``), or ``None``."""
    import typing

    from pydantic import BaseModel

    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return annotation
    return next((m for m in map(_model_in, typing.get_args(annotation)) if m is not None), None)


def field_names(model, loc: list) -> set[str]:
    """The field names a request may hold at ``loc`` (the place of a field it does not take), by the request model;
    empty where the model does not say (a mapping's keys)."""
    for part in loc[:-1]:
        if isinstance(part, int):
            continue
        field = next((f for n, f in model.model_fields.items() if part in (n, f.alias)), None)
        model = _model_in(field.annotation) if field is not None else None
        if model is None:
            return set()
    return {f.alias or n for n, f in model.model_fields.items()}


def close_match(error: dict, spec, upload: bool) -> str:
    """`` (did you mean 'points'?)`` for a field the request does not take (a misspelt key) when one it takes is
    close, else nothing. An upload's ``--options`` may set the kind's options and the request's own fields."""
    import difflib

    from plantsolve.app.dashboard_views import options_model

    loc = list(error.get("loc") or [])
    if spec is None or error.get("type") != "extra_forbidden" or not loc or not isinstance(loc[-1], str):
        return ""
    if upload and loc[:1] == ["options"] and len(loc) == 2:
        names = set(options_model(spec).model_fields) | set(spec.request_model.model_fields)
    else:
        names = field_names(spec.request_model, loc)
    close = difflib.get_close_matches(loc[-1], sorted(names), n=1, cutoff=0.6)
    return f" (did you mean {close[0]!r}?)" if close else ""


def problem_lines(problem: dict, options: dict | None, spec=None, upload: bool = False) -> str:
    """A problem document as a headline and one line per bad field. A field the command's ``--options`` set is
    named as such (its value came from there, not from the input file); a field the request does not take is given
    the close match among those it takes (with the kind's ``spec``)."""
    head, errors = problem.get("title", "error"), problem.get("errors") or []
    if errors:  # the detail repeats the fields' messages: the lines below say them once each
        head = f"{head} ({len(errors)} field{'s' if len(errors) > 1 else ''}):"
    elif problem.get("detail"):
        head = f"{head}: {problem['detail']}"
    lines = [f"plantsolve: {head}"]
    for error in errors:
        loc = list(error.get("loc") or [])
        inner = loc[1:] if loc[:1] == ["options"] else loc
        from_options = options is not None and bool(inner) and inner[0] in options
        lines.append(f"  {'--options ' if from_options else ''}{field_path(inner if from_options else loc)}: "
                     f"{error.get('msg', '')}{close_match(error, spec, upload)}")
    if errors:
        lines.append("  (--json prints the whole problem document)")
    return "\n".join(lines)


def failure_lines(job_id: str, status: str, report: dict | None, output: str | None) -> str:
    """A failed job in a few lines: its stage and message, each input error, where the whole report went."""
    report = report or {}
    stage = f" at stage '{report['stage']}'" if report.get("stage") else ""
    lines = [f"job {job_id} {status}{stage}: {report.get('message', '')}"]
    for error in (report.get("details") or {}).get("errors") or []:
        if isinstance(error, dict):
            lines.append(f"  {field_path(list(error.get('loc') or []))}: {error.get('msg', '')}")
    lines.append(f"  the report is in {output}" if output else "  (--json prints the whole report)")
    return "\n".join(lines)


def _wants_progress(args: argparse.Namespace) -> bool:
    """``--progress``/``--no-progress``; by default a bar only where someone watches (standard error is a terminal)."""
    return args.progress if args.progress is not None else sys.stderr.isatty()


class JobProgressBar:
    """A progress bar on standard error for a job that runs in this process: a thread reads the job's progress
    from its row (where the runner writes it, as for any job), so the run itself stays the service's."""

    def __init__(self, service, job_id: uuid.UUID, kind: str, *, enabled: bool, period: float = 0.1) -> None:
        self.service, self.job_id, self.kind, self.enabled, self.period = service, job_id, kind, enabled, period
        self._done = threading.Event()
        self._thread: threading.Thread | None = None

    def __enter__(self) -> "JobProgressBar":
        if not self.enabled:
            return self
        from rich.console import Console
        from rich.progress import BarColumn, Progress, TaskProgressColumn, TextColumn, TimeElapsedColumn

        # a terminal's codes even when standard error is redirected: --progress asked for the bar
        console = Console(stderr=True, force_terminal=True)
        self._bar = Progress(TextColumn("{task.description}"), BarColumn(), TaskProgressColumn(), TimeElapsedColumn(),
                             console=console, auto_refresh=False)
        self._task = self._bar.add_task(self.kind, total=1.0)
        self._bar.start()
        self._thread = threading.Thread(target=self._follow, name="progress-bar", daemon=True)
        self._thread.start()
        return self

    def _show(self) -> None:
        state = self.service.state(self.job_id)
        if state is None:
            return
        message = f"{self.kind}: {state.progress_message}" if state.progress_message else self.kind
        self._bar.update(self._task, completed=state.progress, description=message[:60])
        self._bar.refresh()

    def _follow(self) -> None:
        while not self._done.wait(self.period):
            try:
                self._show()
            except Exception:  # a busy database: the next read will do
                pass

    def __exit__(self, *exc: Any) -> None:
        if self._thread is None:
            return
        self._done.set()
        self._thread.join()
        try:
            self._show()  # the final state: 100 % for a finished job
        finally:
            self._bar.stop()


def _write(output: str | None, payload, stream=sys.stdout) -> None:
    text = json.dumps(payload, indent=2)
    if output:
        Path(output).parent.mkdir(parents=True, exist_ok=True)
        Path(output).write_text(text + "\n")
    else:
        print(text, file=stream)


class HelpFormatter(argparse.ArgumentDefaultsHelpFormatter, argparse.RawDescriptionHelpFormatter):
    """Every option's default after its help; none where the help says in words what happens without it."""

    def _get_help_string(self, action: argparse.Action) -> str | None:
        if action.default is None or action.default is argparse.SUPPRESS:
            return action.help
        return super()._get_help_string(action)


def version() -> str:
    from importlib.metadata import PackageNotFoundError
    from importlib.metadata import version as installed

    try:
        return installed("plantsolve")
    except PackageNotFoundError:  # run from a source tree that was never installed
        return "unknown"


def kinds_epilog(kinds: Mapping[str, Any]) -> str:
    """The kinds, one line each: what they solve and which files they read."""
    width = max(map(len, kinds))
    lines = ["kinds:"]
    for kind in sorted(kinds):
        spec = kinds[kind]
        files = ", ".join(spec.upload_extensions) or "JSON request only"
        lines.append(f"  {kind:<{width}}  {(spec.description or '').split('. ')[0].rstrip('.')} [{files}]")
    defaults = {kind: field.default for kind in sorted(kinds)
                if (field := kinds[kind].request_model.model_fields.get("units")) is not None
                and isinstance(field.default, str)}
    lines.append(textwrap.fill(
        "units: a file's numbers are read in the unit the file states (a column header 'x [m]', an IFC unit "
        "assignment, LDraw units, EnergyPlus metres); a file that states none is read in the request's 'units', "
        f"by default {', '.join(f'{k} {u}' for k, u in defaults.items())} (--options '{{\"units\": \"m\"}}'; "
        "'file_units' for the file alone), and the run says so on standard error. Every number of a result is in "
        "the unit its result's 'units' fields name; each field's unit is in /docs of a server (x-unit).",
        width=118, initial_indent="\n", subsequent_indent="  "))
    lines.append("\nJSON requests, options and result fields of every kind: README.md (Solvers), /docs of a server.")
    return "\n".join(lines)


def build_parser(kinds: Mapping[str, Any] | None = None, *, describe_kinds: bool = True) -> argparse.ArgumentParser:
    """The command line; ``kinds`` (the kind map) makes ``solve``'s KIND a choice among them, and with
    ``describe_kinds`` the help describes each (which imports every kind's package: its spec and schemas; a run of
    one kind imports that one alone). Without the map (every command but ``solve``) neither the settings nor the
    schemas are read, so that ``--help`` and ``--version`` answer at once."""
    parser = argparse.ArgumentParser(prog="plantsolve", description=__doc__.split("\n\n")[0].replace("``", ""),
                                     formatter_class=HelpFormatter)
    parser.add_argument("--version", action="version", version=f"%(prog)s {version()}")
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    log_levels = LOG_LEVELS

    serve = commands.add_parser("serve", formatter_class=HelpFormatter,
                                help="start the API (and, without BROKER_URL, the in-process job pool)",
                                description="Start the API. Without BROKER_URL it also runs the jobs, in processes it\n"
                                "supervises. The database is migrated at start (AUTO_MIGRATE). Further settings\n"
                                "come from the environment (README.md, Settings).")
    serve.add_argument("--host", default="127.0.0.1",
                       help="address to listen on; 0.0.0.0 for every interface (then set API_KEYS)")
    serve.add_argument("--port", type=int, default=8000,
                       help="TCP port to listen on; a busy port is refused before anything starts")
    serve.add_argument("--log-level", default=None, choices=log_levels,
                       help="least severe log line written, by uvicorn and the plantsolve loggers of the API and its job "
                       "processes (default: LOG_LEVEL, else info)")
    serve.set_defaults(func=cmd_serve, command_parser=serve)

    worker = commands.add_parser("worker", formatter_class=HelpFormatter,
                                 help="start a Celery worker (scaled mode, needs BROKER_URL)",
                                 description="Start a Celery worker that runs jobs from BROKER_URL (scaled mode).")
    worker.add_argument("--concurrency", type=int, default=2, help="jobs run at once (worker processes)")
    worker.add_argument("--hostname", default=None,
                        help="the worker's node name (default: Celery's, celery@<host name>)")
    worker.add_argument("--log-level", default=None, choices=log_levels,
                        help="least severe log line written, by Celery and the plantsolve loggers (default: LOG_LEVEL, "
                        "else info)")
    worker.set_defaults(func=cmd_worker, command_parser=worker)

    solve = commands.add_parser("solve", formatter_class=HelpFormatter,
                                help="run one job in this process and write its result",
                                description=__doc__.split("\n\n")[1].replace("``", ""),
                                epilog=kinds_epilog(kinds) if kinds and describe_kinds
                                else "kinds: see 'plantsolve solve --help'")
    if kinds:
        solve.add_argument("kind", choices=sorted(kinds), metavar="KIND",
                           help=f"solver kind: one of {', '.join(sorted(kinds))} (below)")
    else:
        solve.add_argument("kind", metavar="KIND", help="solver kind")
    solve.add_argument("input", metavar="INPUT",
                       help="request JSON, or a file the solver reads (PCF, PLY, CSV, ...; the kinds' files below)")
    solve.add_argument("-o", "--output", metavar="OUT", help="result JSON (default: standard output)")
    solve.add_argument("--options", metavar="JSON",
                       help="JSON object of options for a file input, as the upload form's 'options', e.g. "
                       "'{\"units\": \"m\"}' for lengths in metres (default: none; the kind's defaults, its units "
                       "below)")
    solve.add_argument("--artifacts", metavar="DIR",
                       help="folder for artifacts (default: <OUT stem>_artifacts next to OUT; without -o a new "
                       "temporary folder, named on standard error)")
    where = solve.add_mutually_exclusive_group()
    where.add_argument("--store", metavar="URL",
                       help="database to record the job in (e.g. the server's DATABASE_URL, to see it on the "
                       "dashboard); default: a temporary store of this run only")
    where.add_argument("--data-dir", metavar="DIR",
                       help="DATA_DIR whose SQLite database and artifact folder record the job (the server's: 'var'); "
                       "default: a temporary store of this run only")
    solve.add_argument("--json", action="store_true",
                       help="print an invalid input's problem document and a failure's report as JSON on standard "
                       "error, instead of one line per field")
    solve.add_argument("--log-level", default=None, choices=log_levels,
                       help="also print the run's log lines (the job runner's, third-party libraries', Python "
                       "warnings) at this level and above on standard error (default: none; the report's warnings "
                       "are printed either way)")
    solve.add_argument("--progress", action=argparse.BooleanOptionalAction, default=None,
                       help="a progress bar on standard error while the job runs (default: when standard error is "
                       "a terminal)")
    solve.set_defaults(func=cmd_solve, command_parser=solve)

    migrate = commands.add_parser("migrate", formatter_class=HelpFormatter, help="upgrade the database schema",
                                  description="Upgrade the database (DATABASE_URL, or DATA_DIR's SQLite file) to the\n"
                                  "newest schema revision.")
    migrate.set_defaults(func=cmd_migrate, command_parser=migrate)
    return parser


def _command(argv: list[str]) -> str | None:
    """The command named on the command line (the first word that is no option)."""
    return next((word for word in argv if not word.startswith("-")), None)


def _kinds() -> Mapping[str, Any]:
    from plantsolve.solvers.kinds import load_kinds

    return load_kinds(_settings().plugins)


def _single_threaded_blas() -> None:
    """Jobs already run in parallel (pool threads, Celery processes); a multithreaded BLAS on
    top oversubscribes the cores and made a 6 ms least-squares step take 330 ms on 2 cores.
    Must run before numpy is first imported; an explicit setting wins."""
    for name in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(name, "1")


M_MMAP_THRESHOLD = -3  # glibc's mallopt parameter (malloc.h)
MMAP_THRESHOLD_BYTES = 4 << 20  # 1 MiB kept 20 MB less and cost 0.4 s more in page faults (a million triangles)


def _fixed_mmap_threshold() -> None:
    """Blocks of 4 MiB and more mapped on their own, so that freeing them gives them back to the system. glibc's
    default threshold grows to the size of each large block freed (up to 32 MiB): a solve's arrays of a few MiB
    then come from the heap, which keeps them after they are freed, and the next stage (the artifacts) piled on
    top of the last one's peak (a million triangles: 1,210 MiB instead of some 850 with the per-face table). Not
    glibc (musl, macOS): nothing to do."""
    try:
        ctypes.CDLL(None).mallopt(M_MMAP_THRESHOLD, MMAP_THRESHOLD_BYTES)
    except (OSError, AttributeError):
        pass


def _configure_logs(argv: list[str]) -> None:
    """Where log lines go before any library is imported. ``serve`` and ``worker``: nowhere yet, the service's own
    set-up (JSON lines, third-party lines and Python warnings included) follows. The other commands print their
    own lines; log lines of the job's run and of third-party libraries (pint's unit definitions, matplotlib's
    warnings), and Python warnings, only with ``--log-level``."""
    if _command(argv) in ("serve", "worker"):
        return
    logging.captureWarnings(True)
    wanted = argparse.ArgumentParser(add_help=False)
    wanted.add_argument("--log-level")
    level = wanted.parse_known_args(argv)[0].log_level
    if level in LOG_LEVELS:  # (another value is refused by the command's parser)
        logging.basicConfig(level=level.upper(), format="%(levelname)s %(name)s: %(message)s")
    else:  # a handler that drops them (without any, Python's last resort prints warnings to stderr)
        logging.basicConfig(handlers=[logging.NullHandler()])


def main(argv: list[str] | None = None) -> int:
    _single_threaded_blas()
    argv = sys.argv[1:] if argv is None else argv
    if _command(argv) == "solve":
        gc.disable()  # until the job's modules are imported (_collect_from_now_on)
        _fixed_mmap_threshold()
    _configure_logs(argv)
    # the kind map (the settings for its plugins) only for solve; every kind's package only for its help
    wants_help = bool({"-h", "--help"} & set(argv))
    args, extras = build_parser(_kinds() if _command(argv) == "solve" else None,
                                describe_kinds=wants_help).parse_known_args(argv)
    if extras:
        refuse_unknown(args.command_parser, extras)
    return args.func(args)


def refuse_unknown(parser: argparse.ArgumentParser, extras: list[str]) -> None:
    """Exit 2 naming the first word the command does not take, with the option it most likely meant (argparse's own
    message names no close match, and comes with the usage of ``plantsolve`` rather than of the command)."""
    import difflib

    word = extras[0]
    if not word.startswith("-"):
        parser.error(f"unexpected argument {word!r} (one INPUT per run)" if parser.prog.endswith(" solve")
                     else f"unexpected argument {word!r}")
    names = [o for a in parser._actions for o in a.option_strings if o.startswith("--")]
    close = difflib.get_close_matches(word.split("=", 1)[0], names, n=1, cutoff=0.6)
    parser.error(f"unknown option {word.split('=', 1)[0]}" + (f"; did you mean {close[0]}?" if close else
                                                               f"; the options are {', '.join(names)}"))


if __name__ == "__main__":
    sys.exit(main())
