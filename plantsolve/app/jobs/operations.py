"""``POST /v1/<kind>/jobs/{id}/<operation>``: each kind's synchronous result operations.

Routes come from the ``operations`` of every solver spec (perfmap's inverse query is one), so
a kind adds a route by declaring it, not by editing the app factory. No postponed annotations
in this module: FastAPI reads each operation's request model from the handler's signature.
"""

import uuid
from typing import Mapping

from fastapi import APIRouter, Depends

from plantsolve.app.auth import require_api_key
from plantsolve.app.deps import Caller, Service, known_query
from plantsolve.app.jobs.endpoints import camel
from plantsolve.app.problems import responses
from plantsolve.solvers.base import ResultOperation, SolverSpec


def operation_route(spec: SolverSpec, operation: ResultOperation):
    request_model = operation.request_model

    def answer(job_id: uuid.UUID, body: request_model, service: Service, caller: Caller):  # type: ignore[valid-type]
        return service.answer(spec, operation, job_id, body, caller.sees)

    answer.__name__ = f"{spec.kind}_{operation.name}".replace("-", "_")
    return answer


def _example(operation: ResultOperation) -> dict | None:
    if operation.example is None:
        return None
    return {"requestBody": {"content": {"application/json": {"example": operation.example()}}}}


def build_operations_router(kinds: Mapping[str, SolverSpec]) -> APIRouter:
    router = APIRouter(prefix="/v1", dependencies=[Depends(require_api_key), Depends(known_query)],
                       responses=responses(401, 500))
    for kind in sorted(kinds):
        spec = kinds[kind]
        for operation in spec.operations:
            router.add_api_route(
                f"/{kind}/jobs/{{job_id}}/{operation.name}",
                operation_route(spec, operation),
                methods=["POST"],
                response_model=operation.response_model,
                responses=responses(404, 409, 413, 422),
                tags=[kind],
                operation_id=f"{camel(operation.name)[:1].lower()}{camel(operation.name)[1:]}{camel(kind)}Job",
                openapi_extra=_example(operation),
                summary=operation.summary or f"{operation.name} on a finished {kind} job",
                description=operation.description,
            )
    return router
