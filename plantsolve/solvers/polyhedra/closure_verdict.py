"""The report-level verdicts of a run whose volumes are not all known.

A zone that is not closed (or whose faces cannot be oriented, or repeat, or vanished in the merge) gets
``volume: null`` and a warning of its own; the result's ``total_volume`` is null with it. Those warnings are caveats
to a reader skimming the report: a job that 'succeeded' with status ``warning`` reads as a pass. The question a
polyhedra job answers is the volume, so a zone without one is a verdict against the result — ``NOT DETERMINED`` —
which the job view, the CLI's exit status and the dashboard show beside 'succeeded'. So is a file cut short before
its data ends (an IFC cut mid-entity): the zones read may all close, but the totals are theirs, not the building's.
"""

from __future__ import annotations

from plantsolve.schemas.common import Diagnostic

_LISTED = 5


def _why(zone: dict, codes: dict[str, set[str]]) -> str:
    said = codes.get(zone["id"], set())
    if "zone_without_faces" in said:
        return "no face left after merging"
    if "duplicate_faces" in said:
        return "faces listed twice"
    if not zone["closed"]:
        return f"not closed, {zone['open_edge_count']} open edge(s)"
    return "faces cannot be oriented consistently"


def volumes_not_determined(zones: list[dict], warnings: list[Diagnostic]) -> Diagnostic | None:
    """The verdict naming the zones whose volume is not given (each with why), or None when every zone has one."""
    missing = [z for z in zones if z["volume"] is None]
    if not missing:
        return None
    codes: dict[str, set[str]] = {}
    for w in warnings:
        zone = (w.details or {}).get("zone")
        if isinstance(zone, str):
            codes.setdefault(zone, set()).add(w.code)
    named = "; ".join(f"{z['id']!r}: {_why(z, codes)}" for z in missing[:_LISTED])
    more = f"; and {len(missing) - _LISTED} more" if len(missing) > _LISTED else ""
    return Diagnostic(code="volume_not_determined", message=(
        f"Volume not determined for {len(missing)} of {len(zones)} zone(s) ({named}{more}): their volume and "
        "total_volume are null. Close the zones (the open edges are listed per zone) and send the file again."),
        details={"zones": [z["id"] for z in missing], "zones_total": len(zones)})


def _read_to_cut(cut: object) -> bool:
    """Whether ``cut`` has the shape the IFC reader gives ``source.read_to_cut``."""
    counts = ("line", "spaces_named", "spaces_measured", "objects_past_cut")
    return (isinstance(cut, dict) and isinstance(cut.get("format"), str)
            and all(isinstance(cut.get(k), int) and not isinstance(cut.get(k), bool) for k in counts)
            and isinstance(cut.get("spaces_not_measured"), list)
            and all(isinstance(label, str) for label in cut["spaces_not_measured"]))


def totals_not_determined(source: dict | None) -> Diagnostic | None:
    """The verdict of a file read only as far as its cut (``source.read_to_cut``: what the reader counted before
    it), or None when the file is whole."""
    cut = source.get("read_to_cut") if isinstance(source, dict) else None
    if not _read_to_cut(cut):  # a JSON body's own 'source' is free text: only the reader's shape counts
        return None
    named, measured, past = cut["spaces_named"], cut["spaces_measured"], cut["objects_past_cut"]
    lacking = cut["spaces_not_measured"]
    said = [f"{named} IfcSpace(s) named before the cut"]
    if lacking:
        said.append(f"{len(lacking)} of them not measured ({', '.join(lacking[:_LISTED])}"
                    f"{' …' if len(lacking) > _LISTED else ''})")
    if past:
        said.append(f"{past} more object(s) a storey or building aggregates lie past the cut")
    return Diagnostic(code="totals_not_determined", message=(
        f"Totals not determined: the {cut['format']} file was cut short (line {cut['line']}), so total_volume and "
        f"total_floor_area are those of the {measured} space(s) read, not the building's — {'; '.join(said)}; spaces "
        "wholly past the cut, or named only by relations written after it, cannot be counted. Send the whole file."),
        details={"line": cut["line"], "spaces_named": named, "spaces_measured": measured,
                 "spaces_not_measured": lacking, "objects_past_cut": past})
