"""Prometheus metrics on ``GET /metrics``, computed from the database at scrape time.

Every number comes from the job rows, not from counters in this process: the API may run as several
processes (and jobs in Celery workers elsewhere), and each of them answers a scrape with the same
totals. A scrape costs three grouped queries.

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

from plantsolve.jobs.lifecycle import STATUSES

RUN_SECONDS_BUCKETS = (0.1, 0.5, 1.0, 2.5, 5.0, 10.0, 30.0, 60.0, 120.0, 300.0, 600.0, 1800.0, 3600.0)


class JobsCollector:
    def __init__(self, jobs, kinds):
        self.jobs, self.kinds = jobs, kinds

    def collect(self):
        counts = {(kind, status): 0 for kind in self.kinds for status in STATUSES}
        for kind, status, n in self.jobs.count_by_kind_status():
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
        waiting = dict(self.jobs.oldest_queued())
        for kind in sorted(set(self.kinds) | set(waiting)):
            oldest.add_metric([kind], max(0.0, (now - waiting[kind]).total_seconds()) if kind in waiting else 0.0)
        runs = HistogramMetricFamily("plantsolve_job_run_seconds", "Run time of finished jobs (their last attempt).",
                                     labels=["kind", "status"])
        for kind, status, count, total, cumulative in self.jobs.run_time_histogram(RUN_SECONDS_BUCKETS):
            buckets = [(str(bound), n) for bound, n in zip(RUN_SECONDS_BUCKETS, cumulative)] + [("+Inf", count)]
            runs.add_metric([kind, status], buckets, total)
        yield from (jobs, queue, oldest, runs)


def build_metrics(jobs, kinds) -> APIRouter:
    registry = CollectorRegistry(auto_describe=False)
    registry.register(JobsCollector(jobs, kinds))
    router = APIRouter(include_in_schema=False)

    @router.get("/metrics")
    async def metrics(request: Request) -> Response:
        return Response(await run_in_threadpool(generate_latest, registry), media_type=CONTENT_TYPE_LATEST)

    return router
