"""The rooms of the design picture and the direction of their imports, read from the source.

app → jobs → store, solvers; workers (transport) → jobs; only app/main.py and the CLI assemble a
process with workers; schemas are imported by everyone and import nothing of ours.
"""

from __future__ import annotations

import ast
import functools
import tomllib
from pathlib import Path

import pytest

from tests.conftest import REPO

PACKAGE = REPO / "plantsolve"

# room -> rooms it may import (besides itself)
ALLOWED = {
    "schemas": set(),
    "solvers": {"schemas"},
    "store": {"schemas"},
    "jobs": {"store", "solvers", "schemas"},
    "workers": {"jobs", "solvers", "schemas"},
    "app": {"jobs", "solvers", "schemas"},
    "cli": {"app", "jobs", "store", "workers", "solvers", "schemas"},
    "client": set(),  # the HTTP client stands alone: a script with only httpx can copy it
}
# single modules a room may import beyond its rooms: the store writes only the lifecycle's transitions
# (a leaf module), and the app's main module assembles the process with its transport
EXTRA = {
    "store": {"plantsolve.jobs.lifecycle"},
    "app/main.py": {"plantsolve.workers.dispatch", "plantsolve.workers.logs"},
}


@functools.cache
def _import_statements(path: Path) -> tuple[tuple[ast.Import | ast.ImportFrom, bool], ...]:
    """A file's import statements at any depth, each with whether it is at the module's top level: parsed once per
    test process, as three checks read every source file; only these nodes are kept, not the whole tree."""
    tree = ast.parse(path.read_text(), filename=str(path))
    top_level = {id(node) for node in tree.body}
    return tuple((node, id(node) in top_level) for node in ast.walk(tree) if isinstance(node, (ast.Import, ast.ImportFrom)))


def _imports(path: Path) -> set[str]:
    """Every plantsolve module a file imports, at any depth (function-level imports too)."""
    names: set[str] = set()
    for node, _ in _import_statements(path):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                raise AssertionError(f"{path}: relative import (use absolute plantsolve.… imports)")
            names.add(node.module or "")
    return {name for name in names if name == "plantsolve" or name.startswith("plantsolve.")}


def _room(path: Path) -> str:
    parts = path.relative_to(PACKAGE).parts
    return parts[0].removesuffix(".py") if len(parts) > 1 or parts[0] in ("cli.py", "client.py") else "root"


SOURCES = sorted(p for p in PACKAGE.rglob("*.py") if "migrations" not in p.parts or p.name == "env.py")


@pytest.mark.parametrize("path", SOURCES, ids=lambda p: str(p.relative_to(REPO)))
def test_imports_run_one_way(path):
    room = _room(path)
    if room == "root":
        return
    extra = EXTRA.get(room, set()) | EXTRA.get(str(path.relative_to(PACKAGE)), set())
    for name in _imports(path):
        target = name.split(".")[1] if "." in name else "plantsolve"
        assert target == room or target in ALLOWED[room] or name in extra, \
            f"{path.relative_to(REPO)}: {room} imports {name}"


def test_the_lifecycle_module_imports_only_schemas():
    """The store may import the lifecycle because the lifecycle depends on nothing but the schemas."""
    assert _imports(PACKAGE / "jobs" / "lifecycle.py") <= {"plantsolve.schemas.jobs"}


def test_only_plantsolve_is_installed():
    config = tomllib.loads((REPO / "pyproject.toml").read_text())
    assert config["tool"]["setuptools"]["packages"]["find"]["include"] == ["plantsolve*"]
    for old in ("app", "workers", "solvers", "schemas"):
        assert not (REPO / old).exists(), f"top-level package {old!r} is back"
    assert {p.name for p in PACKAGE.iterdir() if p.is_dir() and not p.name.startswith("__")} == {
        "app", "jobs", "store", "workers", "solvers", "schemas"}


def test_every_kind_uses_the_same_file_names_for_the_same_roles():
    from plantsolve.solvers.kinds import KINDS

    roles = {"__init__.py", "solve.py", "validation.py", "upload.py", "artifacts.py", "synthetic.py"}
    for kind in KINDS:
        files = {p.name for p in (PACKAGE / "solvers" / kind).glob("*.py")}
        assert roles <= files, f"{kind} lacks {roles - files}"
        assert not files & {"pipeline.py", "validate.py", "pointio.py", "plots.py", "simulate.py"}


def test_no_comment_points_outside_the_repository():
    import re

    pattern = re.compile(r"\bissue\s*#?\d+|design\.md", re.IGNORECASE)
    files = [*SOURCES, *(REPO / "tests").rglob("*.py"), *(REPO / "bench").rglob("*.py"), *(REPO / "examples").rglob("*.md")]
    offenders = [f"{p.relative_to(REPO)}:{i}" for p in files for i, line in enumerate(p.read_text().splitlines(), 1)
                 if pattern.search(line) and p.name != "test_layout.py"]
    assert not offenders, offenders


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(REPO).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _is_module(name: str) -> bool:
    base = REPO.joinpath(*name.split("."))
    return base.with_suffix(".py").exists() or (base / "__init__.py").exists()


def test_no_import_cycles_and_no_imports_hidden_in_functions():
    """Module-level imports form no cycle, so none has to be hidden in a function to break one.
    Only the CLI imports lazily (so ``plantsolve --help`` does not load numpy or FastAPI), and the
    dispatcher choice imports the Celery one only in scaled mode (Celery is the [scaled] extra, not
    installed by ``make run``)."""
    import networkx as nx

    graph = nx.DiGraph()
    hidden = []
    for path in SOURCES:
        module = _module_name(path)
        statements = _import_statements(path)
        for node, top_level in statements:
            if top_level and isinstance(node, ast.ImportFrom) and (node.module or "").startswith("plantsolve"):
                for alias in node.names:
                    target = f"{node.module}.{alias.name}"
                    graph.add_edge(module, target if _is_module(target) else node.module)
        for node, top_level in statements:
            if not top_level:
                names = [node.module or ""] if isinstance(node, ast.ImportFrom) else [a.name for a in node.names]
                if any(n.startswith("plantsolve") for n in names) and path.name != "cli.py" and "migrations" not in path.parts \
                        and path.relative_to(REPO).as_posix() != "plantsolve/workers/dispatch.py":
                    hidden.append(f"{path.relative_to(REPO)}:{node.lineno}")
    cycles = list(nx.simple_cycles(graph))
    assert not cycles, cycles
    assert not hidden, f"plantsolve imports inside functions: {hidden}"


def test_no_private_name_is_imported_from_another_module():
    offenders = []
    for path in sorted([*PACKAGE.rglob("*.py"), *(REPO / "tests").rglob("*.py"), *(REPO / "bench").rglob("*.py")]):
        for node, _ in _import_statements(path):
            if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("plantsolve"):
                offenders += [f"{path.relative_to(REPO)}:{node.lineno} {alias.name}" for alias in node.names
                              if alias.name.startswith("_") and not alias.name.startswith("__")]
    assert not offenders, offenders


def test_every_read_of_a_job_is_typed_as_the_one_job_record():
    """The repository hands out one shape of job, whatever query made it, and the job domain passes it on typed."""
    import typing

    from plantsolve.jobs.service import JobService, Submitted
    from plantsolve.store.repository import JobRecord, JobRepository

    for method in (JobRepository.get, JobRepository.get_by_idempotency_key, JobRepository.list, JobRepository.create,
                   JobService.get, JobService.cancel):
        hint = typing.get_type_hints(method)["return"]
        assert JobRecord in (hint, *typing.get_args(hint), *(a for arg in typing.get_args(hint)
                                                             for a in typing.get_args(arg))), (method, hint)
    assert typing.get_type_hints(Submitted)["job"] is JobRecord


def test_the_store_decides_nothing_about_lost_attempts():
    """The lease policy lives in jobs/leases.py: the repository takes no report builder or policy callback and
    names no outcome of an attempt."""
    source = (PACKAGE / "store" / "repository.py").read_text()
    for word in ("report_for_lost", "result_waiting", '"lost"', '"result_pending"', "max_attempts = attempt"):
        assert word not in source, word
