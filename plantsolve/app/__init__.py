"""HTTP: the FastAPI application, its settings, auth, submissions, kind operations, job reads, artifacts, dashboard."""
