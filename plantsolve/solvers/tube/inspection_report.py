"""An inspection's outcome at the level of the report: a part out of tolerance, a nominal of another bend count
or rows the scan cannot decide make the job a warning, first in its list, and the summary says so in words
(a green job whose inspection failed is a confident wrong answer)."""

from __future__ import annotations

from plantsolve.schemas.common import Diagnostic, Report
from plantsolve.schemas.tube import Inspection, InspectionRow

FIELD_UNIT = {"length": "{u}", "bend_radius": "{u}", "rotation": "deg", "angle": "deg"}


def _fields(rows: list[InspectionRow], which: str) -> list[str]:
    """The fields named in the rows' ``which`` list, in the order of the LRA columns."""
    names = {f for r in rows for f in getattr(r, which)}
    return [f for f in ("length", "rotation", "angle", "bend_radius") if f in names]


def _rows_text(rows: list[InspectionRow], which: str) -> str:
    picked = [r for r in rows if getattr(r, which)]
    return f"rows {', '.join(str(r.row) for r in picked)} ({', '.join(_fields(picked, which))})"


def _field_details(rows: list[InspectionRow], which: str, units: str) -> list[dict]:
    out = []
    for r in rows:
        for name in getattr(r, which):
            check = getattr(r, name)
            out.append({"row": r.row, "field": name, "nominal": check.nominal, "measured": check.measured,
                        "deviation": check.deviation, "tolerance": check.tolerance, "sigma": check.sigma,
                        "bound": check.bound, "unit": FIELD_UNIT[name].format(u=units)})
    return out


def inspection_outcome(ins: Inspection, units: str) -> tuple[str, Diagnostic | None]:
    """The summary's clause (``inspection FAIL: rows 1, 2 (angle)``) and the warning of a verdict other than
    'pass' (None on a pass)."""
    if ins.verdict == "not_comparable":
        text = (f"the nominal has {ins.nominal_bends} bend(s), the scan {ins.measured_bends}: no row can be "
                "compared (only the sheath deviation is given)")
        return f"inspection NOT COMPARABLE: {text}", Diagnostic(
            code="inspection_not_comparable", message=f"Inspection not comparable: {text}. Check that the nominal "
            "belongs to this part, or whether a bend was merged or split (report.details.pruned).",
            details={"nominal_bends": ins.nominal_bends, "measured_bends": ins.measured_bends,
                     "sheath_deviation": ins.sheath_deviation})
    bad_ends = [e for e in ins.end_points if e.ok is False]
    open_ends = [e for e in ins.end_points if not e.determined]
    if ins.verdict == "fail":
        parts = [_rows_text(ins.rows, "failed")] if ins.failed_rows else []
        if bad_ends:
            parts.append("end points " + ", ".join(f"{e.end} {e.deviation:.3g} {units}" for e in bad_ends)
                         + f" off (tolerance {bad_ends[0].tolerance:.3g} {units})")
        text = "; ".join(parts)
        if ins.undetermined_rows:  # the rows the samples leave open are named beside the failures
            text += f"; not determined: {_rows_text(ins.rows, 'undetermined')}"
        return f"inspection FAIL: {text}", Diagnostic(
            code="inspection_failed", message=f"Inspection FAIL: {text} out of tolerance (corrections for the next "
            "part in inspection.corrections).",
            details={"rows": ins.failed_rows, "fields": _fields(ins.rows, "failed"),
                     "failed": _field_details(ins.rows, "failed", units),
                     "end_points": [e.end for e in bad_ends], "undetermined_rows": ins.undetermined_rows})
    if ins.verdict == "not_determined":
        parts = [_rows_text(ins.rows, "undetermined")] if ins.undetermined_rows else []
        if open_ends:
            parts.append("end points " + ", ".join(e.end for e in open_ends))
        text = "; ".join(parts)
        return f"inspection NOT DETERMINED: {text}", Diagnostic(
            code="inspection_not_determined", message=f"Inspection not determined: the samples do not determine "
            f"{text} (an end straight they stop short on, a bend seen from one side, a sigma larger than the "
            "tolerance, or within the tolerance by less than three sigmas (the part may end further on)); every "
            "determined field is within tolerance. Scan those parts of the tube again, or "
            "measure them.",
            details={"rows": ins.undetermined_rows, "fields": _fields(ins.rows, "undetermined"),
                     "undetermined": _field_details(ins.rows, "undetermined", units),
                     "end_points": [e.end for e in open_ends]})
    return "inspection PASS", None


def report_inspection(report: Report, ins: Inspection, units: str) -> None:
    """The inspection's outcome in ``report``: the summary extended, its warning first, status 'warning'."""
    clause, warning = inspection_outcome(ins, units)
    report.message = f"{report.message.rstrip('.')}; {clause}."
    report.details["inspection_verdict"] = ins.verdict
    if warning is not None:
        report.warnings.insert(0, warning)
    for w in ins.warnings:  # the nominal CSV's skipped lines
        if all(w.message != x.message for x in report.warnings):
            report.warnings.append(w)
    if report.warnings:
        report.status = "warning"
