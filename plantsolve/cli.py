"""``plantsolve`` command line: serve, worker, solve, migrate.

``plantsolve solve KIND INPUT [-o OUT]`` runs one job through the same submission checks and
the same runner as the service, in a store of its own (not the server's database, unless ``--store`` or
``--data-dir`` names it); the result goes to OUT or standard output, artifacts to ``--artifacts DIR``
(default next to OUT, or a temporary folder), warnings with their codes to standard error. Exit
codes: 0 success, 2 invalid input (the problem is printed), 1 solver failure (the report is written).
"""

from __future__ import annotations

import argparse
import gc
import json
import logging
import os
import sys
import tempfile
import uuid
from pathlib import Path


def _settings():
    from plantsolve.app.settings import get_settings

    return get_settings()


def cmd_serve(args: argparse.Namespace) -> int:
    import uvicorn

    from plantsolve.app.auth import warn_if_exposed
    from plantsolve.app.main import create_app

    app = create_app()
    warn_if_exposed(args.host, app.state.keys)
    # Everything imported so far (numpy, scipy, every solver kind) lives as long as the process: out of
    # the collector's sight, a full collection no longer walks it and stalls requests for tens of ms.
    gc.collect()
    gc.freeze()
    uvicorn.run(app, host=args.host, port=args.port, log_level=args.log_level)
    return 0


def cmd_worker(args: argparse.Namespace) -> int:
    settings = _settings()
    if not settings.broker_url:
        print("plantsolve worker needs BROKER_URL (e.g. redis://127.0.0.1:6379/0); "
              "without it jobs run inside 'plantsolve serve'.", file=sys.stderr)
        return 2
    from plantsolve.workers.celery_app import create_celery

    celery_app = create_celery(settings)
    argv = ["worker", f"--loglevel={args.log_level.upper()}", f"--concurrency={args.concurrency}", "--pool=prefork"]
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
    if args.store or args.data_dir:
        updates: dict = {}
        if args.data_dir:
            updates["data_dir"] = Path(args.data_dir)
        if args.store:
            updates["database_url"] = args.store
        return settings.model_copy(update=updates)
    return settings.model_copy(update={"data_dir": scratch, "database_url": None, "artifact_dir": None})


def _artifact_folder(args: argparse.Namespace) -> Path:
    """``--artifacts``, else ``<OUT stem>_artifacts`` next to ``-o OUT``, else a new temporary folder (the
    result went to standard output: nothing is written into the current directory unasked)."""
    if args.artifacts:
        return Path(args.artifacts)
    if args.output:
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
        print(f"plantsolve: no such file: {path}", file=sys.stderr)
        return 2
    with tempfile.TemporaryDirectory(prefix="plantsolve-cli-") as scratch:
        return _solve(args, path, _solve_settings(args, Path(scratch)))


def _solve(args: argparse.Namespace, path: Path, settings) -> int:
    from plantsolve.jobs.context import ServiceContext, worker_name
    from plantsolve.jobs.errors import ProblemError
    from plantsolve.jobs.lifecycle import SUCCEEDED
    from plantsolve.jobs.runner import run_job
    from plantsolve.jobs.service import JobService

    ctx = ServiceContext.create(settings, migrate=True)
    try:
        dispatcher = _InlineDispatcher()
        service = JobService(ctx, dispatcher)
        content = path.read_bytes()
        try:
            if path.suffix.lower() == ".json" and args.options is None:
                submitted = service.submit_json(args.kind, content, None)
            else:
                submitted = service.submit_upload(args.kind, path.name, content, args.options, None)
        except ProblemError as error:
            print(json.dumps(error.to_problem().model_dump(mode="json", exclude_none=True), indent=2),
                  file=sys.stderr)
            return 2
        job_id = submitted.job.id
        name = worker_name("cli")
        while dispatcher.pending:
            run_job(ctx, dispatcher.pending.pop(0), worker=name, requeue=dispatcher.enqueue)
        job = service.get(job_id)
        if job.status == SUCCEEDED:
            _write(args.output, job.result)
            artifacts = service.view(job).artifacts
            if artifacts:
                folder = _artifact_folder(args)
                folder.mkdir(parents=True, exist_ok=True)
                for artifact in artifacts:
                    (folder / artifact.name).write_bytes(service.artifact(job_id, artifact.name)[1].read())
                print(f"artifacts: {', '.join(a.name for a in artifacts)} in {folder}", file=sys.stderr)
            report = job.report or (job.result or {}).get("report")
            n = _print_warnings(report)
            print(f"job {job_id} succeeded" + (f" with {n} warning(s) (above)" if n else ""), file=sys.stderr)
            return 0
        _write(args.output, {"job": str(job_id), "status": job.status, "report": job.report}, stream=sys.stderr)
        _print_warnings(job.report)
        print(f"job {job_id} {job.status}: {(job.report or {}).get('message', '')}", file=sys.stderr)
        return 1
    finally:
        ctx.close()


def _write(output: str | None, payload, stream=sys.stdout) -> None:
    text = json.dumps(payload, indent=2)
    if output:
        Path(output).parent.mkdir(parents=True, exist_ok=True)
        Path(output).write_text(text + "\n")
    else:
        print(text, file=stream)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="plantsolve", description=__doc__.split("\n\n")[0])
    commands = parser.add_subparsers(dest="command", required=True)

    serve = commands.add_parser("serve", help="start the API (and, without BROKER_URL, the in-process job pool)")
    serve.add_argument("--host", default="127.0.0.1")
    serve.add_argument("--port", type=int, default=8000)
    serve.add_argument("--log-level", default="info")
    serve.set_defaults(func=cmd_serve)

    worker = commands.add_parser("worker", help="start a Celery worker (scaled mode, needs BROKER_URL)")
    worker.add_argument("--concurrency", type=int, default=2)
    worker.add_argument("--hostname", default=None)
    worker.add_argument("--log-level", default="info")
    worker.set_defaults(func=cmd_worker)

    solve = commands.add_parser("solve", help="run one job in this process and write its result")
    solve.add_argument("kind")
    solve.add_argument("input", help="request JSON, or a file the solver reads (PCF, PLY, CSV, ...)")
    solve.add_argument("-o", "--output", help="result JSON (default: standard output)")
    solve.add_argument("--options", help="JSON object of options for a file input")
    solve.add_argument("--artifacts", metavar="DIR",
                       help="folder for artifacts (default: <OUT stem>_artifacts next to OUT; without -o a new "
                       "temporary folder, named on standard error)")
    where = solve.add_mutually_exclusive_group()
    where.add_argument("--store", metavar="URL",
                       help="database to record the job in (e.g. the server's DATABASE_URL, to see it on the "
                       "dashboard); default: a temporary store of this run only")
    where.add_argument("--data-dir", metavar="DIR",
                       help="DATA_DIR whose SQLite database and artifact folder record the job (the server's: 'var')")
    solve.set_defaults(func=cmd_solve)

    migrate = commands.add_parser("migrate", help="upgrade the database schema")
    migrate.set_defaults(func=cmd_migrate)
    return parser


def _single_threaded_blas() -> None:
    """Jobs already run in parallel (pool threads, Celery processes); a multithreaded BLAS on
    top oversubscribes the cores and made a 6 ms least-squares step take 330 ms on 2 cores.
    Must run before numpy is first imported; an explicit setting wins."""
    for name in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(name, "1")


def main(argv: list[str] | None = None) -> int:
    _single_threaded_blas()
    logging.basicConfig(level=logging.WARNING, format="%(levelname)s %(name)s: %(message)s")
    args = build_parser().parse_args(argv)
    return args.func(args)


if __name__ == "__main__":
    sys.exit(main())
