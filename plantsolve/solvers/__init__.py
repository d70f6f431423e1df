"""Pure numerics. Each ``solvers/<name>/`` package exposes one public entry

    solve(request: schemas.<name>.<Name>Request, progress: Progress) -> schemas.<name>.<Name>Result

and optionally ``parse_upload`` (file bytes -> request) and ``render_artifacts``
(request + result -> files). Nothing here imports FastAPI, Celery or SQLAlchemy, and
nothing keeps global state.
"""
