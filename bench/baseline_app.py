"""The trivial app that bench/api.py measures the service against, under the same uvicorn settings.

FastAPI + SQLite (WAL), one table: ``POST /v1/jobs`` parses the JSON body, inserts a row and answers
202 with the id; ``GET /v1/jobs/{id}`` reads the row back as JSON. No validation, no auth, no queue,
no workers: the floor of what a Python submit/read route on this machine costs.

    python bench/baseline_app.py --port 18800 --db /tmp/baseline.db
"""

from __future__ import annotations

import argparse
import json
import sqlite3
import threading
import uuid

import uvicorn
from fastapi import FastAPI, HTTPException, Request, Response


def create_app(db_path: str) -> FastAPI:
    local = threading.local()

    def connection() -> sqlite3.Connection:
        if not hasattr(local, "db"):
            local.db = sqlite3.connect(db_path, timeout=30, isolation_level=None)
            local.db.execute("PRAGMA journal_mode=WAL")
            local.db.execute("PRAGMA synchronous=NORMAL")
        return local.db

    connection().execute("CREATE TABLE IF NOT EXISTS jobs (id TEXT PRIMARY KEY, status TEXT, input TEXT)")
    app = FastAPI()

    @app.post("/v1/jobs", status_code=202)
    def submit(body: dict) -> Response:
        job_id = str(uuid.uuid4())
        connection().execute("INSERT INTO jobs VALUES (?, 'queued', ?)", (job_id, json.dumps(body)))
        return Response(json.dumps({"id": job_id, "status": "queued"}), status_code=202, media_type="application/json")

    @app.get("/v1/jobs/{job_id}")
    def read(job_id: str, request: Request) -> Response:
        row = connection().execute("SELECT id, status, input FROM jobs WHERE id = ?", (job_id,)).fetchone()
        if row is None:
            raise HTTPException(404)
        return Response(json.dumps({"id": row[0], "status": row[1], "input": json.loads(row[2])}),
                        media_type="application/json")

    return app


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--port", type=int, required=True)
    parser.add_argument("--db", required=True)
    args = parser.parse_args()
    uvicorn.run(create_app(args.db), host="127.0.0.1", port=args.port, log_level="warning")


if __name__ == "__main__":
    main()
