"""What an upload's reader left in the request it made: the warnings a job's report carries whatever the solve does.

A kind's solve puts them first in a successful report; a failed job has no result to carry them, so the runner puts
them in the failure report (a scan read with an assumed encoding or converted units, then a solve that fails, must
not lose the word on how its file was read). Found without knowing the kind, by the two forms the readers share:

- typed: every :class:`~plantsolve.schemas.common.Diagnostic` the request holds in its fields (tube's
  ``source.warnings``, perfmap's ``upload_warnings``), its sub-models walked field by field (lists of models, a
  scan's points, are not walked: a reader's notes are a field of their own);
- plain: a ``source`` mapping as :mod:`plantsolve.solvers.skipped_input` describes it (polyhedra, rigidity): its
  ``warnings``, and its ``skipped`` records said as one warning.
"""

from __future__ import annotations

from typing import Any, Iterator, Mapping

from pydantic import BaseModel

from plantsolve.schemas.common import Diagnostic
from plantsolve.solvers.skipped_input import skipped_lines, source_warnings

# nesting of sub-models walked: a request's reader notes sit a level or two down
DEPTH = 4


def reader_warnings(request: Any) -> list[dict]:
    """The reader's warnings of ``request`` (a kind's request model), as report entries, each once, in order."""
    found: list[Diagnostic] = list(_typed(request, DEPTH))
    source = getattr(request, "source", None)
    if isinstance(source, Mapping):
        skipped = [s for s in source.get("skipped") or [] if isinstance(s, dict)]
        if skipped:
            count = source.get("skipped_count")
            found.append(skipped_lines(skipped, "record", count if isinstance(count, int) else None))
        found.extend(source_warnings(source))
    seen: set[tuple[str, str]] = set()
    entries = []
    for diagnostic in found:
        if (diagnostic.code, diagnostic.message) not in seen:
            seen.add((diagnostic.code, diagnostic.message))
            entries.append(diagnostic.model_dump(mode="json"))
    return entries


def _typed(value: Any, depth: int) -> Iterator[Diagnostic]:
    if isinstance(value, Diagnostic):
        yield value
    elif isinstance(value, BaseModel) and depth > 0:
        for name in type(value).model_fields:
            yield from _typed(getattr(value, name, None), depth - 1)
    elif isinstance(value, (list, tuple)) and value and isinstance(value[0], Diagnostic):
        yield from (item for item in value if isinstance(item, Diagnostic))


def with_reader_warnings(report: dict | None, warnings: list[dict]) -> dict | None:
    """``report`` with the reader's ``warnings`` first (those it does not carry already)."""
    if report is None or not warnings:
        return report
    held = {(w.get("code"), w.get("message")) for w in report.get("warnings") or [] if isinstance(w, dict)}
    added = [w for w in warnings if (w["code"], w["message"]) not in held]
    return {**report, "warnings": [*added, *(report.get("warnings") or [])]} if added else report
