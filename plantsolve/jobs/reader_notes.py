"""What an upload's reader left in the request it made: the warnings a job's report carries whatever the solve does.

A kind's solve puts them first in a successful report; a failed job has no result to carry them, so the runner puts
them in the failure report (a scan read with an assumed encoding or converted units, then a solve that fails, must
not lose the word on how its file was read). Found without knowing the kind, by the two forms the readers share:

- typed: every :class:`~plantsolve.schemas.common.Diagnostic` the request holds in its fields (tube's
  ``source.warnings``, perfmap's ``upload_warnings``), its sub-models walked field by field (lists of models, a
  scan's points, are not walked: a reader's notes are a field of their own);
- plain: a ``source`` mapping as :mod:`plantsolve.solvers.skipped_input` describes it (polyhedra, rigidity): its
  ``warnings``, and its ``skipped`` records said as one warning;
- said again: a kind whose request keeps only its source's text (alignment's PCF) names in its spec the function that
  says the reader's notes again from it (``SolverSpec.reader_notes``); its notes of level ``warning``.

The runner writes them into the job's report as soon as it has read the input (:func:`reading_report`), so that an
attempt that ends without a word from its process (killed, out of memory, its lease lapsed) still has them: the lease
policy's report keeps the warnings of the report it replaces (:func:`held`).
"""

from __future__ import annotations

from typing import Any, Iterator, Mapping

from pydantic import BaseModel

from plantsolve.schemas.common import Diagnostic, Report
from plantsolve.solvers.base import SolverSpec
from plantsolve.solvers.skipped_input import skipped_lines, source_warnings

# nesting of sub-models walked: a request's reader notes sit a level or two down
DEPTH = 4


def reader_warnings(request: Any, spec: SolverSpec | None = None) -> list[dict]:
    """The reader's warnings of ``request`` (a request model of ``spec``'s kind), as report entries, each once, in
    order."""
    found: list[Diagnostic] = list(_typed(request, DEPTH))
    source = getattr(request, "source", None)
    if isinstance(source, Mapping):
        skipped = [s for s in source.get("skipped") or [] if isinstance(s, dict)]
        if skipped:
            count = source.get("skipped_count")
            found.append(skipped_lines(skipped, "record", count if isinstance(count, int) else None))
        found.extend(source_warnings(source))
    if spec is not None and spec.reader_notes is not None:
        found.extend(Diagnostic(code=code, message=message, details=details)
                     for code, message, details, level in spec.reader_notes(request) if level == "warning")
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


def reading_report(warnings: list[dict]) -> dict:
    """The report a running attempt writes once it has read its input with ``warnings``: what the job's report says
    until the attempt ends (its message stays empty: the attempt's progress says what it does)."""
    return Report(status="warning", warnings=warnings).model_dump(mode="json")


def held(report: dict | None) -> list[dict]:
    """The reader's warnings held in the report of a job that has not finished: its only warnings then (the report of
    an earlier attempt that failed or was lost, or the one its running attempt wrote on reading the input: each
    carries the reader's warnings and no others)."""
    return [w for w in (report or {}).get("warnings") or [] if isinstance(w, dict) and "code" in w and "message" in w]
