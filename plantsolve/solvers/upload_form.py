"""A request read from an uploaded file with the upload form's options laid over it (rigidity, polyhedra).

Validated in two steps so that each 422 names where the bad value came from: the form's own fields
first (``("options", "merge_tolerance")``, ``("units",)``), then the merged request, inside ``file``."""

from __future__ import annotations

from functools import cache
from typing import TypeVar

from pydantic import BaseModel, create_model

from plantsolve.solvers.base import merge_upload_options, validated

Request = TypeVar("Request", bound=BaseModel)
FORM_FIELDS = ("units", "options")  # what merge_upload_options takes from the form


@cache
def form_model(request_model: type[BaseModel]) -> type[BaseModel]:
    """The request's fields an upload form may set, as a model of their own (same types, same defaults)."""
    fields = {name: (request_model.model_fields[name].annotation, request_model.model_fields[name])
              for name in FORM_FIELDS}
    return create_model(f"{request_model.__name__}Form", __config__=request_model.model_config, **fields)


def validated_upload(request_model: type[Request], body: dict, options: dict | None) -> Request:
    """``body`` (read from the file) with the form's ``options`` merged in, validated as ``request_model``."""
    if options:
        validated(form_model(request_model), merge_upload_options({}, options), ())
    return validated(request_model, merge_upload_options(body, options), ("file",))
