"""What a file says about its own zones (gbXML's ``Space/Volume`` and ``Space/Area``) against what
the solver measures: a table in the report's details and one warning when they differ by more than 1 %."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from plantsolve.schemas.common import Diagnostic
from plantsolve.solvers.polyhedra.file_units import METRES

TOLERANCE = 0.01  # relative


def unit_mix_up(ratio: float, power: int) -> str | None:
    """'declared in ft³, read as m³' when measured / declared is the factor between two length units to ``power``
    (within TOLERANCE), else None."""
    for declared_in, a in METRES.items():
        for read_as, b in METRES.items():
            if declared_in != read_as and abs(ratio / (a / b) ** power - 1) <= TOLERANCE:
                sup = {2: "²", 3: "³"}[power]
                return f"the declared value looks like {declared_in}{sup} taken as {read_as}{sup}"
    return None


def compare(declared: Mapping[str, Mapping[str, Any]], zones: Sequence[Mapping[str, Any]],
            floors: Mapping[str, float]) -> tuple[list[dict], Diagnostic | None]:
    """Rows of declared and measured volume (m3 or units3) and floor area per zone the file declares."""
    rows, differ, mixes = [], [], []
    for zone in zones:
        claim = declared.get(zone["id"])
        if not isinstance(claim, Mapping):
            continue
        row: dict[str, Any] = {"zone": zone["id"]}
        for key, measured in (("volume", zone.get("volume")), ("floor_area", floors.get(zone["id"]))):
            value = claim.get(key)
            if not isinstance(value, (int, float)) or value <= 0:
                continue
            row[f"declared_{key}"] = float(value)
            row[key] = measured
            if measured is not None:
                row[f"{key}_difference"] = (measured - value) / value
                if abs(measured - value) > TOLERANCE * value:
                    differ.append(zone["id"])
                    mix = unit_mix_up(measured / value, {"volume": 3, "floor_area": 2}[key])
                    if mix:
                        row[f"{key}_likely"] = mix
                        mixes.append(f"{zone['id']!r} {key.replace('_', ' ')}: {mix}")
        if len(row) > 1:
            rows.append(row)
    warning = None
    if differ:
        names = sorted(set(differ))
        warning = Diagnostic(code="declared_measures_differ", message=(
            f"{len(names)} zone(s) measure more than {TOLERANCE:.0%} away from the volume or floor area the file "
            "declares for them (see details.declared_comparison)" + (
                f"; by a unit's factor: {'; '.join(mixes[:3])}" if mixes else "") + "."),
            details={"zones": names[:1000], "unit_mix_ups": mixes[:1000]})
    return rows, warning
