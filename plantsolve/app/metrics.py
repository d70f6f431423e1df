"""Prometheus metrics on ``GET /metrics``, computed from the database at scrape time.

Every number comes from the job rows, not from counters in this process: the API may run as several
processes (and jobs in Celery workers elsewhere), and each of them answers a scrape with the same
totals. A scrape costs three grouped queries.

With API keys, a tenant's key sees the counts of its own jobs only (the queries filter on the owner);
an admin key (``ADMIN_KEYS``), or a service without keys, sees every tenant's.

- ``plantsolve_jobs{kind,status}``: jobs in the database;
- ``plantsolve_queue_depth{kind}`` and ``plantsolve_queue_oldest_seconds{kind}``: queued jobs and how long the
  oldest has waited;
- ``plantsolve_job_run_seconds{kind,status}``: a histogram of the finished jobs' run time (the attempt that
  finished each one).
"""

from __future__ import annotations

from datetime import datetime, timezone

from fastapi import APIRouter, Request, Response
from prometheus_client import CONTENT_TYPE_LATEST, CollectorRegistry, generate_latest
from prometheus_client.core import GaugeMetricFamily, HistogramMetricFamily
from starlette.concurrency import run_in_threadpool

from plantsolve.app.auth import principal
from plantsolve.jobs.lifecycle import STATUSES

RUN_SECONDS_BUCKETS = (0.1, 0.5, 1.0, 2.5, 5.0, 10.0, 30.0, 60.0, 120.0, 300.0, 600.0, 1800.0, 3600.0)


class JobsCollector:
    """The job metrics as ``sees`` may see them: None every tenant's jobs, an owner only its own."""

    def __init__(self, jobs, kinds, sees: str | None = None):
        self.jobs, self.kinds, self.sees = jobs, kinds, sees

    def collect(self):
        counts = {(kind, status): 0 for kind in self.kinds for status in STATUSES}
        for kind, status, n in self.jobs.count_by_kind_status(self.sees):
            counts[(kind, status)] = n
        jobs = GaugeMetricFamily("plantsolve_jobs", "Jobs in the database by kind and status.", labels=["kind", "status"])
        queue = GaugeMetricFamily("plantsolve_queue_depth", "Jobs waiting for a worker (queued), by kind.", labels=["kind"])
        for (kind, status), n in sorted(counts.items()):
            jobs.add_metric([kind, status], n)
            if status == "queued":
                queue.add_metric([kind], n)
        oldest = GaugeMetricFamily("plantsolve_queue_oldest_seconds", "How long the oldest queued job has waited, by kind.",
                                   labels=["kind"])
        now = datetime.now(timezone.utc)
        waiting = dict(self.jobs.oldest_queued(self.sees))
        for kind in sorted(set(self.kinds) | set(waiting)):
            oldest.add_metric([kind], max(0.0, (now - waiting[kind]).total_seconds()) if kind in waiting else 0.0)
        runs = HistogramMetricFamily("plantsolve_job_run_seconds", "Run time of finished jobs (their last attempt).",
                                     labels=["kind", "status"])
        for kind, status, count, total, cumulative in self.jobs.run_time_histogram(RUN_SECONDS_BUCKETS, self.sees):
            buckets = [(str(bound), n) for bound, n in zip(RUN_SECONDS_BUCKETS, cumulative)] + [("+Inf", count)]
            runs.add_metric([kind, status], buckets, total)
        yield from (jobs, queue, oldest, runs)


def scrape(jobs, kinds, sees: str | None) -> bytes:
    """One scrape in the exposition format; a registry per scrape, since what it shows depends on the caller."""
    registry = CollectorRegistry(auto_describe=False)
    registry.register(JobsCollector(jobs, kinds, sees))
    return generate_latest(registry)


def build_metrics(jobs, kinds) -> APIRouter:
    router = APIRouter(include_in_schema=False)

    @router.get("/metrics")
    async def metrics(request: Request) -> Response:
        sees = principal(request).sees  # the auth middleware has refused callers without a valid key
        return Response(await run_in_threadpool(scrape, jobs, kinds, sees), media_type=CONTENT_TYPE_LATEST)

    return router
