"""The IFC project's one length unit. IfcOpenShell's unit scale multiplies every LENGTHUNIT its IfcUnitAssignment
lists, and its geometry kernel takes one of them by their order: a project listing MILLIMETRE and FOOT gave 60 m³
rooms listed one way round and 1.7e9 m³ the other, with the report's file unit 0.0003048 m either way. IFC allows
one unit per type and which one the coordinates are in is not known: refused naming both. One unit listed twice is
that unit."""

from __future__ import annotations

from plantsolve.solvers.base import reject

AGREE = 1e-3  # relative difference of two sizes that are one unit written twice


def project_length_scale(model) -> float:
    """Metres per unit of the project's length unit (1 when it assigns none); a 422 on ``file`` naming the units
    when it assigns two of different sizes."""
    import ifcopenshell.util.unit  # third-party, only needed for IFC

    projects = model.by_type("IfcProject")
    assignment = projects[0].UnitsInContext if projects else None
    units = [u for u in (assignment.Units if assignment is not None else ()) or ()
             if getattr(u, "UnitType", None) == "LENGTHUNIT"]
    scales = [float(ifcopenshell.util.unit.get_unit_scale(u)) for u in units]
    if not scales:
        return 1.0
    if any(abs(s - scales[0]) > AGREE * abs(scales[0]) for s in scales[1:]):
        named = [f"{u.Prefix or ''}{u.Name}" if u.is_a("IfcSIUnit") else str(u.Name) for u in units]
        listed = " and ".join(f"{n} (#{u.id()}, {s:g} m)" for n, u, s in zip(named, units, scales, strict=True))
        raise reject(f"the IFC project's IfcUnitAssignment assigns {len(units)} length units, {listed}: IFC allows "
                     "one unit per type, and which one the coordinates are in is not known (the zones' volumes differ "
                     "by the cube of their ratio). Keep the one the model was drawn in", ("file",))
    return scales[0]
