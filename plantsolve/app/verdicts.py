"""Whether a finished job's result answers what was asked, for the surfaces that show it.

The verdict codes and the value type are the schema's (``plantsolve.schemas.common``: ``VERDICT_CODES``,
``ReportVerdict``, ``verdicts_of``, ``Report.verdict``): "succeeded" alone would read as a pass where a warning says the answer is
*no*, so every surface says the verdict beside it: the CLI exits 3 (see ``plantsolve/cli.py``), the dashboard shows
a badge and a banner, the API's job view and result carry ``report.verdict``, and the client's ``Job.verdict`` reads
it (``plantsolve/client.py`` keeps a copy of the codes for reports stored before the field: it imports nothing of
plantsolve; a test keeps the two equal).
"""

from __future__ import annotations

from typing import Any


def report_warnings(report: Any) -> list[Any]:
    """A report's warnings, whether the report is the stored dict or the ``Report`` model (``None``: none)."""
    if report is None:
        return []
    return list((report.get("warnings") if isinstance(report, dict) else report.warnings) or [])
