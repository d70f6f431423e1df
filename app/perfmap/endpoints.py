"""``POST /v1/perfmap/jobs/{id}/query``: best (theta, phi) for duty points on a finished map.

Answered synchronously from the stored result: the query is a pure, fast function of it.
"""

import uuid

from fastapi import APIRouter, Depends

from app.auth import require_api_key
from app.jobs.endpoints import Service
from app.problems import Conflict, NotFound, responses
from schemas.perfmap import PerfmapQueryRequest, PerfmapQueryResult, PerfmapResult
from solvers.perfmap import query


def build_router() -> APIRouter:
    router = APIRouter(prefix="/v1/perfmap", dependencies=[Depends(require_api_key)], tags=["perfmap"])

    @router.post(
        "/jobs/{job_id}/query",
        response_model=PerfmapQueryResult,
        responses=responses(401, 404, 409, 422),
        summary="Inverse query: optimal settings and efficiency for duty points",
        description="One `{flow, pressure}` or `{points: [...]}`. Points outside the reachable region "
        "come back with `feasible: false` and their distance to the map instead of an extrapolation.",
    )
    def query_map(job_id: uuid.UUID, body: PerfmapQueryRequest, service: Service) -> PerfmapQueryResult:
        job = service.get(job_id)
        if job.kind != "perfmap":
            raise NotFound(f"Job {job_id} is a {job.kind!r} job, not a performance map.")
        if job.status != "succeeded":
            raise Conflict(f"Job {job_id} is {job.status}; only a finished map can be queried.", extra={"status": job.status})
        result = PerfmapResult.model_validate(job.result)
        if result.map is None:
            raise Conflict(f"Job {job_id} computed no map (too few settings or map disabled); nothing to query.")
        return query(result, body)

    return router
