"""What a file reader could not read, said in the report's warnings (never only in its details).

Readers go on item by item: a line or object they cannot read is skipped, and a file that ends
inside a record (cut in transfer, an export that stopped) is read up to its last whole record. Both
must reach ``report.warnings`` so that a job that succeeded on part of its input never looks clean:

- ``truncated_file``: the file ends inside a record; details name the ``line`` where that record
  starts (1-based, as an editor shows it) and what was lost;
- ``skipped_lines``: records that could not be read; details list the first ``lines`` (up to
  :data:`LINES_LISTED`), their ``count`` and the ``skipped`` entries with their reasons.

A reader keeps these as plain dicts in its request's ``source`` (``source["warnings"]``), because
the request is what the worker re-reads; :func:`source_warnings` turns them back into diagnostics
for the solve's report.
"""

from __future__ import annotations

from typing import Any, Mapping, Sequence


from pydantic import ValidationError

from plantsolve.schemas.common import Diagnostic
from plantsolve.solvers.base import reject

LINES_LISTED = 10  # line numbers named in a message and its details; the count says how many more
ENTRIES_LISTED = 200  # skipped entries (with reasons) kept in a warning's details


def line_list(lines: Sequence[int]) -> str:
    """'7', '7 and 9', '7, 9 and 12', or '7, 9, …, 30 (and 12 more)': the first few lines and a count."""
    shown = [str(n) for n in lines[:LINES_LISTED]]
    rest = len(lines) - len(shown)
    if rest:
        return f"{', '.join(shown)} (and {rest} more)"
    return shown[0] if len(shown) == 1 else f"{', '.join(shown[:-1])} and {shown[-1]}"


def ends_mid_line(text: str) -> bool:
    """The text's last line has no line ending although its other lines have one: exporters end every
    line, so a file cut in transfer shows here. A one-line text proves nothing."""
    body = text.rstrip(" \t\x00\x1a")  # NUL padding, the DOS end-of-file mark
    return bool(body) and not body.endswith(("\n", "\r")) and ("\n" in body or "\r" in body)


def truncated_file(line: int, message: str, **details: Any) -> Diagnostic:
    """The file ends inside the record that starts at ``line``; ``message`` says what that cost."""
    return Diagnostic(code="truncated_file", message=f"The file ends inside the record at line {line}: {message}",
                      details={"line": line, **details})


def skipped_lines(skipped: Sequence[Mapping[str, Any]], what: str = "line", count: int | None = None,
                  code: str = "skipped_lines") -> Diagnostic:
    """One warning for every record of the file that was skipped; each entry has its ``line`` and ``reason``.
    ``count`` is the number skipped when ``skipped`` lists only the first of them; ``code`` is a kind's own
    name for it where it has one (perfmap's ``upload_rows_skipped``)."""
    count = len(skipped) if count is None else max(count, len(skipped))
    lines = sorted({int(s["line"]) for s in skipped if isinstance(s.get("line"), int)})
    first = skipped[0] if skipped else {}
    where = f" at line {line_list(lines)}" if lines else ""
    # without a line number (an IFC entity, an epJSON object) the object's name is all that tells the user where
    what_first = f"{first['object']}: " if first.get("object") else ""
    why = f"; first: {what_first}{first['reason']}" if first.get("reason") else ""
    return Diagnostic(code=code, message=f"{count} {what}(s) of the file could not be read and were "
                      f"skipped{where}{why}.",
                      details={"lines": lines[:LINES_LISTED], "count": count,
                               "skipped": [dict(s) for s in skipped[:ENTRIES_LISTED]]})


def source_warnings(source: Mapping[str, Any] | None) -> list[Diagnostic]:
    """The diagnostics a reader left in a request's ``source``; entries that are not diagnostics (a hand-written
    JSON request may carry anything there) are not the reader's and are left out."""
    found = []
    for entry in (source or {}).get("warnings") or []:
        try:
            found.append(Diagnostic.model_validate(entry))
        except ValidationError:
            continue
    return found


def refuse_noise_stl(declared: int, whole: int, unreadable: int, why: str) -> None:
    """A 422 on ``file`` for a binary STL cut short (its size disagrees with its triangle count) whose whole
    triangles are mostly unreadable (``unreadable`` of ``whole``, for the reason ``why``): bytes no STL writer
    wrote (random data, another format renamed .stl), whose few passing floats would be read as garbage
    geometry. A real file cut in transfer keeps its whole triangles readable and is read as far as it goes."""
    if 2 * unreadable > whole:
        raise reject(f"not a binary STL: it says {declared} triangles but holds {whole} whole ones, and {unreadable} "
                     f"of those have {why}")
