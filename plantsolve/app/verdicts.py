"""Whether a finished job's result answers what was asked: the few warnings that are a verdict, not a caveat.

A job that succeeded has a result, and its report's status is ``ok`` or ``warning``. Most warnings are caveats on
an answer that stands (a setting fitted less closely, a rotation rounded, a file's unit converted). The codes
below say the answer is *no* or *not known*: a tube out of tolerance or not measurable against its nominal, a fit
that stopped before it converged, an optimized model that failed its own verification, an accuracy asked for and
not reached. "succeeded" alone would read as a pass there, so every surface says the verdict beside it: the CLI
exits 3 (see ``plantsolve/cli.py``), the dashboard shows a badge and a banner, the client's ``Job.verdict`` names
it (``plantsolve/client.py`` keeps a copy of these codes: it imports nothing of plantsolve; a test keeps the two
equal). A kind puts its gravest warning first, so the first of these in a report is the headline.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Iterable

# code → the verdict in a word or two, as the headline says it
VERDICTS: dict[str, str] = {
    "inspection_failed": "FAIL",
    "inspection_not_determined": "NOT DETERMINED",
    "inspection_not_comparable": "NOT COMPARABLE",
    "not_converged": "NOT CONVERGED",
    "verification_failed": "VERIFICATION FAILED",
    "tolerance_not_reached": "TOLERANCE NOT REACHED",
}


@dataclass(frozen=True)
class Verdict:
    """A warning that says the result does not pass: its headline word, code and sentence."""

    label: str
    code: str
    message: str


def _field(warning: Any, name: str) -> str:
    value = warning.get(name) if isinstance(warning, dict) else getattr(warning, name, None)
    return str(value or "")


def verdicts(warnings: Iterable[Any] | None) -> list[Verdict]:
    """The report's warnings (dicts as stored, or ``Diagnostic`` models) that are verdicts, in the report's order."""
    found = []
    for warning in warnings or ():
        code = _field(warning, "code")
        if code in VERDICTS:
            found.append(Verdict(VERDICTS[code], code, _field(warning, "message")))
    return found


def report_warnings(report: Any) -> list[Any]:
    """A report's warnings, whether the report is the stored dict or the ``Report`` model (``None``: none)."""
    if report is None:
        return []
    return list((report.get("warnings") if isinstance(report, dict) else report.warnings) or [])
