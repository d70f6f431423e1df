"""HTTP: the FastAPI application, auth, submissions, job reads, artifacts, dashboard, CLI."""
