"""An IFC project's one length unit, and what its IfcUnitAssignment says against itself (dedup, polyhedra).

IfcOpenShell's unit scale multiplies every LENGTHUNIT the assignment lists, and its geometry kernel takes one of them
by their order: a project listing METRE and a FOOT (IFC allows one unit per type) was reported by dedup as
``length_unit: METRE``, ``units: ft``, 0.3048 m per unit, two MILLI METREs as a micrometre; polyhedra's rooms came out
60 m³ listed one way round and 1.7e9 m³ the other. Which of two different units the coordinates are in is not known:
refused naming both; one unit listed twice is that unit. A unit named FOOT or INCH whose conversion factor is another
unit's (an INCH of 0.3048 m, copied from a foot) is used by its factor, as the geometry kernel uses it, and warned
naming the name and the factor, so that ``length_unit`` and ``units`` do not contradict each other silently."""

from __future__ import annotations

from typing import TYPE_CHECKING

from plantsolve.schemas.common import Diagnostic
from plantsolve.solvers.base import reject

if TYPE_CHECKING:
    import ifcopenshell

# the names IFC's conversion-based length units are written with, and their size in metres
NAMED_M = {"FOOT": 0.3048, "FEET": 0.3048, "INCH": 0.0254, "YARD": 0.9144, "MILE": 1609.344}
AGREE = 1e-3  # a factor written to four digits (0.3048) agrees; a unit copied from another is off by a factor of 12+


def _length_units(model: ifcopenshell.file) -> list:
    projects = model.by_type("IfcProject")
    assignment = projects[0].UnitsInContext if projects else None
    return [u for u in (assignment.Units if assignment is not None else ()) or ()
            if getattr(u, "UnitType", None) == "LENGTHUNIT"]


def _said(unit, scale: float) -> str:
    name = f"{unit.Prefix or ''}{unit.Name}" if unit.is_a("IfcSIUnit") else str(unit.Name)
    return f"{name} (#{unit.id()}, {scale:g} m)"


def project_length_scale(model: ifcopenshell.file, depends: str) -> float:
    """Metres per unit of the project's length unit (1 when it assigns none); a 422 on ``file`` when it assigns
    two of different sizes, saying what ``depends`` on the unit."""
    import ifcopenshell.util.unit  # noqa: PLC0415  (third-party, only needed for IFC: 70 MB of address space)

    units = _length_units(model)
    scales = [float(ifcopenshell.util.unit.get_unit_scale(u)) for u in units]
    if not scales:
        return 1.0
    if any(abs(s - scales[0]) > AGREE * abs(scales[0]) for s in scales[1:]):
        listed = " and ".join(_said(u, s) for u, s in zip(units, scales, strict=True))
        raise reject(f"the IFC project's IfcUnitAssignment assigns {len(units)} length units, {listed}: IFC allows one "
                     "unit per type, and which one the coordinates are in is not known ({depends}). Keep the one the "
                     "model was drawn in", ("file",))
    return scales[0]


def named_unit_warnings(model: ifcopenshell.file) -> list[Diagnostic]:
    """Warning ``length_unit_factor_differs`` for a conversion-based length unit whose name (FOOT, INCH …) states
    another size than its conversion factor."""
    import ifcopenshell.util.unit  # noqa: PLC0415  (third-party, only needed for IFC)

    out = []
    for unit in _length_units(model):
        if not unit.is_a("IfcConversionBasedUnit"):
            continue
        named = NAMED_M.get(str(unit.Name or "").strip().upper())
        factor = float(ifcopenshell.util.unit.get_unit_scale(unit))
        if named is None or abs(factor - named) <= AGREE * named:
            continue
        out.append(Diagnostic(code="length_unit_factor_differs", message=(
            f"The project's length unit #{unit.id()} is named {unit.Name!r} ({named:g} m) but its conversion factor "
            f"makes it {factor:g} m: the lengths, the tolerance and the deviations of the result are read by the "
            f"factor ({factor / named:.4g} times the named unit), as the geometry is. Which one the model was drawn "
            "in is not known: correct the name or the factor."),
            details={"quantity": "length unit", "name": str(unit.Name), "named_metres": named,
                     "factor_metres": factor, "entity": f"#{unit.id()}"}))
    return out
