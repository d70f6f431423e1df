"""What an IFC file cut short names beyond the spaces read from it.

A file cut in transfer is read as far as it goes (``truncated_file``): a space whose body lay past the cut is skipped,
a space wholly past it is not in the model at all, and the totals of the spaces read looked like the building's ('2 of
2 zone(s) closed' for a file naming 3). IfcOpenShell drops a reference to an instance the file lacks without a word,
so the objects past the cut are counted in the text: those the aggregation of a storey, a building or a space
(``IfcRelAggregates``, which most exporters write before the spaces' geometry) lists by an id the model lacks.
"""

from __future__ import annotations

import re
from typing import Any

# an IfcRelAggregates instance whole (its ';' inside strings blanked): its last two attributes, the relating object
# and the list of related ones. Anchored on the ';' ending the instance before (not on line starts, which made the
# scan quadratic in the lines of an instance left open), the closing ';' only looked at so that it anchors the next.
_AGGREGATES = re.compile(r"(?:\A|;)[ \t\r\n]*#\d+[ \t]*=[ \t]*IFCRELAGGREGATES[ \t]*\(([^;]*)\)[ \t\r\n]*(?=;)",
                         re.IGNORECASE)
_RELATED = re.compile(r"#(\d+)[ \t\r\n]*,[ \t\r\n]*\(([^()]*)\)[ \t\r\n]*$")
_ID = re.compile(r"#(\d+)")
def _held(model: Any, number: int) -> Any:
    try:
        return model.by_id(number)
    except RuntimeError:  # no such instance: past the cut
        return None


def aggregated_past_cut(blanked: str, model: Any) -> int:
    """How many objects a spatial element (a storey, a building, a space) aggregates by an id the file does not hold.
    ``blanked``: the file's text with its strings and comments blanked."""
    missing: set[int] = set()
    for relation in _AGGREGATES.finditer(blanked):
        found = _RELATED.search(relation.group(1))
        relating = _held(model, int(found.group(1))) if found else None
        if relating is None or not relating.is_a("IfcSpatialStructureElement"):
            continue
        missing.update(n for n in map(int, _ID.findall(found.group(2))) if _held(model, n) is None)
    return len(missing)
