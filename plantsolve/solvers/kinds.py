"""The kind map: every solver kind the service offers, one line each.

Adding a kind is one solver package exporting ``SPEC``, one schema module and one line here.
Extra kinds for tests and benchmarks come from plugin modules that export ``SPECS`` (named in
the ``PLUGINS`` setting); :func:`load_kinds` returns a new map each call and keeps no state.

Importing the map imports each package's ``__init__`` only: the specs with their schemas, upload
extensions and limits. A spec's functions (solve, readers, checks, artifacts, examples) are imported
when first used, so listing the kinds (``plantsolve solve --help``, the API's routes) costs no solver's
imports and a process that runs one kind imports that kind alone.
"""

from __future__ import annotations

import importlib
from types import MappingProxyType
from typing import Iterable, Mapping

from plantsolve.solvers import alignment, dedup, flowmeter, perfmap, polyhedra, rigidity, tube
from plantsolve.solvers.base import SolverSpec

KINDS: Mapping[str, SolverSpec] = MappingProxyType({
    "alignment": alignment.SPEC,
    "tube": tube.SPEC,
    "perfmap": perfmap.SPEC,
    "polyhedra": polyhedra.SPEC,
    "flowmeter": flowmeter.SPEC,
    "rigidity": rigidity.SPEC,
    "dedup": dedup.SPEC,
})


def load_kinds(plugins: Iterable[str] = ()) -> Mapping[str, SolverSpec]:
    """The built-in kinds plus the ``SPECS`` of each plugin module.

    A plugin that fails to import, exports no ``SPECS``, or reuses a kind is an error: a
    service that silently lost a kind would answer 404 for jobs it used to run.
    """
    kinds = dict(KINDS)
    for name in plugins:
        module = importlib.import_module(name)
        specs = getattr(module, "SPECS", None)
        if specs is None:
            raise ImportError(f"plugin module {name!r} exports no SPECS")
        for spec in specs:
            if not isinstance(spec, SolverSpec):
                raise TypeError(f"plugin module {name!r}: {spec!r} is not a SolverSpec")
            if spec.kind in kinds:
                raise ValueError(f"plugin module {name!r}: kind {spec.kind!r} is already registered")
            kinds[spec.kind] = spec
    return MappingProxyType(kinds)


def _check(kinds: Mapping[str, SolverSpec]) -> None:
    for name, spec in kinds.items():
        if name != spec.kind:
            raise ValueError(f"kind map: key {name!r} holds the spec of {spec.kind!r}")


_check(KINDS)
