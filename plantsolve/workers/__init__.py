"""Transport only: how job ids reach :func:`plantsolve.jobs.runner.run_job` — the supervised process
pool (embedded default), its thread variant, the Celery app and task — plus the sweeper loop and the
log format. Decisions about jobs live in :mod:`plantsolve.jobs`.

Imports the job domain (and the store, solvers and schemas it needs to start a process); imported
only where a process is assembled (``app/main.py``, the CLI).
"""
