"""The kind map: every solver kind the service offers, one line each.

Adding a kind is one solver package exporting ``SPEC``, one schema module and one line in :data:`PACKAGES`.
Extra kinds for tests and benchmarks come from plugin modules that export ``SPECS`` (named in
the ``PLUGINS`` setting); :func:`load_kinds` returns a new map each call and keeps no state.

The map names each kind's package and imports it when that kind is first asked for (``KINDS["tube"]``): a
process that runs one kind (``plantsolve solve tube``) imports that kind's schema alone, and listing the names
(``sorted(KINDS)``, the CLI's choices) imports none. Whoever needs them all says so by asking for them all
(``KINDS.values()``): the API for its routes and OpenAPI document, the warm parent of the job processes and the
upload readers' forkserver, so that no job and no upload waits for an import. A package's ``__init__`` holds its
spec with its schemas, upload extensions and limits; the spec's functions (solve, readers, checks, artifacts,
examples) are imported when first used.
"""

from __future__ import annotations

import importlib
from typing import Iterable, Iterator, Mapping

from plantsolve.solvers.base import SolverSpec

# the one explicit map: kind -> the package whose SPEC it is
PACKAGES: Mapping[str, str] = {
    "alignment": "plantsolve.solvers.alignment",
    "tube": "plantsolve.solvers.tube",
    "perfmap": "plantsolve.solvers.perfmap",
    "polyhedra": "plantsolve.solvers.polyhedra",
    "flowmeter": "plantsolve.solvers.flowmeter",
    "rigidity": "plantsolve.solvers.rigidity",
    "dedup": "plantsolve.solvers.dedup",
}


class KindMap(Mapping[str, SolverSpec]):
    """Read-only kind -> spec. A kind named by its package is imported when it is asked for (Python keeps the
    module, so the map itself holds nothing but the names); a plugin's kind is held as its spec."""

    __slots__ = ("_sources",)

    def __init__(self, packages: Mapping[str, str], specs: Iterable[SolverSpec] = ()) -> None:
        self._sources: dict[str, str | SolverSpec] = {**packages, **{spec.kind: spec for spec in specs}}

    def __getitem__(self, kind: str) -> SolverSpec:
        source = self._sources[kind]
        if isinstance(source, SolverSpec):
            return source
        spec = importlib.import_module(source).SPEC
        if spec.kind != kind:
            raise ValueError(f"kind map: key {kind!r} names {source}, the package of {spec.kind!r}")
        return spec

    def __iter__(self) -> Iterator[str]:
        return iter(self._sources)

    def __len__(self) -> int:
        return len(self._sources)

    def __contains__(self, kind: object) -> bool:
        return kind in self._sources

    def __repr__(self) -> str:
        return f"KindMap({', '.join(self._sources)})"


KINDS: Mapping[str, SolverSpec] = KindMap(PACKAGES)


def load_kinds(plugins: Iterable[str] = ()) -> Mapping[str, SolverSpec]:
    """The built-in kinds plus the ``SPECS`` of each plugin module.

    A plugin that fails to import, exports no ``SPECS``, or reuses a kind is an error: a
    service that silently lost a kind would answer 404 for jobs it used to run.
    """
    extra: dict[str, SolverSpec] = {}
    for name in plugins:
        module = importlib.import_module(name)
        specs = getattr(module, "SPECS", None)
        if specs is None:
            raise ImportError(f"plugin module {name!r} exports no SPECS")
        for spec in specs:
            if not isinstance(spec, SolverSpec):
                raise TypeError(f"plugin module {name!r}: {spec!r} is not a SolverSpec")
            if spec.kind in PACKAGES or spec.kind in extra:
                raise ValueError(f"plugin module {name!r}: kind {spec.kind!r} is already registered")
            extra[spec.kind] = spec
    return KindMap(PACKAGES, extra.values()) if extra else KINDS
