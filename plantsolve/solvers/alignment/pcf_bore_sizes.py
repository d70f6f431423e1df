"""A PCF's bores against the sizes pipe is made in: a bore is a nominal size, NPS in inches or DN in millimetres.

A file whose UNITS-BORE (or UNITS-CO-ORDS, when it states none) says INCH over bores written in millimetres reads
every bore 25.4 times too large, and, its coordinates labelled alike, its whole network 25.4 times too large:
every ratio the solve checks (a fitting's span in bores, a gap against a bore) still agrees, so nothing else says
so. The bores' values do: 100, 150, 65 are DN sizes and no NPS (ASME B36.10 ends at NPS 80 and has no 65 or 150),
and under MM the inch sizes 1/2, 3/4, 1 1/2, 3 are no DN (the smallest is DN 6). When most of the end points'
bores are sizes of the other system only, a warning names the UNITS record's line and a bore's line.
"""

from __future__ import annotations

# ASME B36.10M / B36.19M nominal pipe sizes, inches (NPS 4 1/2 is an older size still written)
NPS_INCH = frozenset({0.125, 0.25, 0.375, 0.5, 0.75, 1.0, 1.25, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 4.5, 5.0, 6.0, 8.0,
                      10.0, 12.0, 14.0, 16.0, 18.0, 20.0, 22.0, 24.0, 26.0, 28.0, 30.0, 32.0, 34.0, 36.0, 38.0, 40.0,
                      42.0, 44.0, 46.0, 48.0, 52.0, 56.0, 60.0, 64.0, 68.0, 72.0, 76.0, 80.0})
# ISO 6708 nominal diameters (DN), millimetres: the metric equivalents B36.10M lists, and the larger EN sizes
DN_MM = frozenset({6.0, 8.0, 10.0, 15.0, 20.0, 25.0, 32.0, 40.0, 50.0, 65.0, 80.0, 90.0, 100.0, 125.0, 150.0, 200.0,
                   250.0, 300.0, 350.0, 400.0, 450.0, 500.0, 550.0, 600.0, 650.0, 700.0, 750.0, 800.0, 850.0, 900.0,
                   950.0, 1000.0, 1050.0, 1100.0, 1150.0, 1200.0, 1300.0, 1400.0, 1500.0, 1600.0, 1700.0, 1800.0,
                   1900.0, 2000.0})
# more than this share of the end points' bores sizes of the other system alone: the unit record is wrong
OTHER_SYSTEM_SHARE = 0.5


def _size(value: float, sizes: frozenset[float]) -> bool:
    return round(value, 4) in sizes


def other_system_bores(bores: list[tuple[int, float]], unit: str) -> tuple[str, list[tuple[int, float]]] | None:
    """When more than :data:`OTHER_SYSTEM_SHARE` of the end points' ``bores`` ((line, bore), in the file's bore
    ``unit``) are sizes of the other system only (DN sizes that are no NPS under inches; NPS sizes below the smallest
    DN under millimetres): the unit they look written in and those end points; None otherwise (other units, too
    few such bores, no bores)."""
    if unit == "in":
        other = [(line, b) for line, b in bores if _size(b, DN_MM) and not _size(b, NPS_INCH)]
        likely = "mm"
    elif unit == "mm":
        other = [(line, b) for line, b in bores if _size(b, NPS_INCH) and not _size(b, DN_MM) and b < min(DN_MM)]
        likely = "in"
    else:
        return None
    if not bores or len(other) <= OTHER_SYSTEM_SHARE * len(bores):
        return None
    return likely, other
