"""Solver registry: ``kind -> (request schema, result schema, solve function, limits)``.

The built-in kinds are the packages under ``solvers/``; each exposes ``solve``,
``check_input``, ``parse_upload``, ``render_artifacts``, ``UPLOAD_EXTENSIONS``,
``TIME_LIMITS`` and ``__version__`` (see ``solvers/__init__.py``). Tests and benchmarks
register extra kinds through :func:`register` from modules named in the ``PLUGINS``
setting, so the Celery worker subprocess sees them too.
"""

from __future__ import annotations

import importlib
import logging
from dataclasses import dataclass, field
from types import ModuleType
from typing import Any, Callable

from pydantic import BaseModel

from solvers.base import Artifact, Progress

log = logging.getLogger("plantsolve.registry")

BUILTIN_KINDS = ("alignment", "tube", "perfmap")


@dataclass(frozen=True)
class SolverSpec:
    kind: str
    request_model: type[BaseModel]
    result_model: type[BaseModel]
    solve: Callable[[Any, Progress], BaseModel]
    version: str
    check_input: Callable[[Any], None] | None = None
    parse_upload: Callable[[str, bytes, dict | None], BaseModel] | None = None
    render_artifacts: Callable[[Any, Any], list[Artifact]] | None = None
    upload_extensions: tuple[str, ...] = ()
    soft_time_limit: float = 600.0
    time_limit: float = 660.0
    max_attempts: int | None = None  # None: the MAX_ATTEMPTS setting
    description: str = ""
    extras: dict[str, Any] = field(default_factory=dict)


_REGISTRY: dict[str, SolverSpec] = {}


def register(spec: SolverSpec) -> SolverSpec:
    _REGISTRY[spec.kind] = spec
    return spec


def unregister(kind: str) -> None:
    _REGISTRY.pop(kind, None)


def get(kind: str) -> SolverSpec | None:
    return _REGISTRY.get(kind)


def kinds() -> list[str]:
    return sorted(_REGISTRY)


def spec_from_package(kind: str, package: ModuleType, request_model, result_model) -> SolverSpec:
    soft, hard = getattr(package, "TIME_LIMITS", (600.0, 660.0))
    return SolverSpec(
        kind=kind,
        request_model=request_model,
        result_model=result_model,
        solve=package.solve,
        version=str(getattr(package, "__version__", "0")),
        check_input=getattr(package, "check_input", None),
        parse_upload=getattr(package, "parse_upload", None),
        render_artifacts=getattr(package, "render_artifacts", None),
        upload_extensions=tuple(getattr(package, "UPLOAD_EXTENSIONS", ())),
        soft_time_limit=float(soft),
        time_limit=float(hard),
        description=(package.__doc__ or "").strip().split("\n\n")[0],
    )


def _load_builtin(kind: str) -> None:
    """Register a built-in solver if its package is present (solvers land one by one)."""
    try:
        package = importlib.import_module(f"solvers.{kind}")
        schema = importlib.import_module(f"schemas.{kind}")
    except ModuleNotFoundError as error:
        if error.name in (f"solvers.{kind}", f"schemas.{kind}"):
            return
        raise
    title = kind.capitalize()
    request_model = getattr(schema, f"{title}Request", None)
    result_model = getattr(schema, f"{title}Result", None)
    if not hasattr(package, "solve") or request_model is None or result_model is None:
        log.warning("solver package %r is incomplete (no solve/%sRequest/%sResult); not registered", kind, title, title)
        return
    register(spec_from_package(kind, package, request_model, result_model))


def load(plugins: list[str] | tuple[str, ...] = ()) -> None:
    """Register the built-in kinds and import the plugin modules (idempotent)."""
    for kind in BUILTIN_KINDS:
        if kind not in _REGISTRY:
            _load_builtin(kind)
    for module in plugins:
        importlib.import_module(module)
