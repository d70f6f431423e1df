"""IFC spaces (``IfcSpace``) as zones: each space's body tessellated by IfcOpenShell's geometry kernel
in world coordinates and metres (its triangles are the zone's faces, ``<zone> t1``, ``t2``, …; coplanar
triangles are fine for the volume), compared with the space's own ``Qto_SpaceBaseQuantities`` (IFC2X3 exporters' ``BaseQuantities``).

Zones are named by the space's ``Name`` (its ``GlobalId`` when the name is missing or not unique);
``source.spaces`` lists GlobalId, Name and LongName. A space the kernel cannot tessellate, without a
representation, or whose body lands beyond the schema's coordinate bound (a garbled placement), is skipped with its
``#id`` and reason; the file is refused (422) when no space is left. A file
cut short (no ``END-ISO-10303-21;`` at its end) is read as far as it goes with a ``truncated_file`` warning,
and a space whose property sets refer to entities the file lacks keeps its zone without declared quantities
(``ifc_quantities_unreadable``).
The quantities ``NetVolume`` (else ``GrossVolume``) and ``NetFloorArea`` (else ``GrossFloorArea``),
converted from the project's volume and area units, go to ``source.declared`` for the solver to set
against what it measures.
"""

from __future__ import annotations

import codecs
import re
from collections import Counter
from typing import Any

import numpy as np

from plantsolve.schemas.common import Diagnostic
from plantsolve.schemas.polyhedra import MAX_COORDINATE
from plantsolve.solvers.base import reject, utf16_without_mark
from plantsolve.solvers.ifc_units import project_length_scale
from plantsolve.solvers.polyhedra.file_units import NONE_ASSIGNED, stated, symbol
from plantsolve.solvers.polyhedra.ifc_cut import aggregated_past_cut
from plantsolve.solvers.polyhedra.ifc_unread import lines_left_out, lines_of_another_schema
from plantsolve.solvers.skipped_input import truncated_file
from plantsolve.solvers.step_file import (
    TRAILER_BYTES,
    blank_strings_and_comments,
    holds_every_instance,
    line_ends,
    where_cut,
)

MAX_SKIPPED_LISTED = 200
VOLUMES_DEPEND = "the zones' volumes differ by the cube of their ratio"  # on the project's length unit


def _scale(model: Any, qto: dict[str, Any], name: str, project: float) -> float:
    """SI units per unit of the quantity ``name`` of the quantity set ``qto`` (get_psets' dict): its own Unit when it
    states one (a quantity in square feet in a metre project), else the project's."""
    import ifcopenshell.util.unit  # noqa: PLC0415  (third-party, only needed for IFC)

    try:
        quantity = next((q for q in getattr(model.by_id(qto["id"]), "Quantities", None) or ()
                         if getattr(q, "Name", None) == name), None)
        unit = getattr(quantity, "Unit", None)
        return float(ifcopenshell.util.unit.get_unit_scale(unit)) if unit is not None else project
    except (KeyError, RuntimeError, TypeError, ValueError, AttributeError):  # a damaged reference: the project's unit
        return project


def _quantity(quantities: dict[str, Any], *names: str) -> tuple[str, float] | None:
    for name in names:
        value = quantities.get(name)
        if isinstance(value, (int, float)) and np.isfinite(value) and value > 0:
            return name, float(value)
    return None


def _unread_schema(text: str) -> str:
    """'; its FILE_SCHEMA 'IFC4X3' …' when the header names a schema IfcOpenShell does not read ('No schema loaded'
    says nothing of which), else ''."""
    from ifcopenshell import ifcopenshell_wrapper  # noqa: PLC0415  (third-party, only needed for IFC)

    found = re.search(r"FILE_SCHEMA\s*\(\s*\(\s*'([A-Za-z0-9_]+)", text[:65536], re.IGNORECASE)
    readable = [name for name in ifcopenshell_wrapper.schema_names() if name.startswith("IFC")]
    if found is None or found.group(1).upper() in readable:
        return ""
    return (f" (its header's FILE_SCHEMA is {found.group(1)!r}; IfcOpenShell reads {', '.join(readable)}: IFC 4.3 as "
            "its final release, 'IFC4X3_ADD2')")


def _beyond_bound(verts: np.ndarray) -> str | None:
    """Why a space's tessellated body is no room (a vertex not finite or past the schema's bound), else None."""
    if not np.isfinite(verts).all():
        return "a vertex of its body is not a finite number (a placement or point of the file is not)"
    worst = float(np.abs(verts).max()) if verts.size else 0.0
    if worst > MAX_COORDINATE:
        return (f"a vertex of its body lies {worst:.3g} m from the origin, beyond ±{MAX_COORDINATE:g} m (a placement "
                "or point of the file is garbled)")
    return None


def parse_ifc(content: bytes) -> dict:
    import ifcopenshell  # noqa: PLC0415  (third-party, only needed for IFC)
    import ifcopenshell.geom  # noqa: PLC0415
    import ifcopenshell.util.element  # noqa: PLC0415
    import ifcopenshell.util.unit  # noqa: PLC0415

    if content[:2] in (codecs.BOM_UTF16_LE, codecs.BOM_UTF16_BE):  # a STEP file re-saved by a Windows editor
        text = content.decode("utf-16", errors="replace")
    elif b"\x00" in content[:4096] and (utf16 := utf16_without_mark(content)) is not None:
        text = utf16
    else:  # ISO 10303-21 text is ISO 8859-1 (other characters escaped); an editor's UTF-8 mark goes
        text = content.removeprefix(codecs.BOM_UTF8).decode("latin-1")
    try:
        model = ifcopenshell.file.from_string(text)
        spaces = model.by_type("IfcSpace")  # a file without a schema fails only here
    except Exception as e:  # the parser raises several kinds for a broken file
        raise reject(f"unreadable IFC file: {str(e) or type(e).__name__}{_unread_schema(text)}") from None
    project_length_scale(model, VOLUMES_DEPEND)  # before the kernel reads the geometry in one of two units
    warnings = []
    cut = where_cut(text[-TRAILER_BYTES:].encode("latin-1", errors="replace"))
    cut_line = line_ends(text, 0, len(text.rstrip())) + 1 if cut is not None else None
    blanked = blank_strings_and_comments(text)  # scanned for instances: a ';#3=B' in a string defines none
    whole = holds_every_instance(blanked)
    if cut is not None:  # the spaces read are whole; those after the cut, and relations written last, are not
        lost = ("Every instance is there; the zones are those of the whole file." if whole else
                "The spaces, quantities and relations after the cut are missing; the zones are those of the spaces read.")
        warnings.append(truncated_file(cut_line, f"the file does not end with 'END-ISO-10303-21;' ({cut}): it was cut "
                                       f"in transfer or export. {lost}", cut=cut).model_dump())
    was_cut = f" (the file was cut short: {cut})" if cut else ""
    left_out = lines_left_out(blanked, model, cut is not None)
    for found in (left_out, lines_of_another_schema(blanked, model)):
        if found is not None:
            warnings.append(found.model_dump())
    if not spaces:
        products = Counter(p.is_a() for p in model.by_type("IfcProduct"))
        held = ", ".join(f"{n} {name}" for name, n in products.most_common(4)) or "no product"
        raise reject(f"the IFC file has no IfcSpace{was_cut}: it holds {sum(products.values())} product(s) "
                     f"({held}) and no space, so it has no zone to measure (a model for dedup? zones are IfcSpace "
                     "bodies)")
    skipped: list[dict] = []
    names = Counter((s.Name or "").strip() for s in spaces)
    zone_of = {s.id(): ((s.Name or "").strip() if (s.Name or "").strip() and names[(s.Name or "").strip()] == 1
                        else s.GlobalId) for s in spaces}
    label = {s.id(): f"#{s.id()} IfcSpace {(s.Name or s.GlobalId)!r}" for s in spaces}
    with_body = [s for s in spaces if s.Representation is not None]
    for s in spaces:
        if s.Representation is None:
            skipped.append({"line": None, "object": label[s.id()], "reason": "no representation"})
    settings = ifcopenshell.geom.settings()
    settings.set("use-world-coords", True)
    vertices: list[np.ndarray] = []
    faces: list[dict] = []
    shaped: set[int] = set()
    garbled: set[int] = set()
    offset = 0
    if with_body:
        iterator = ifcopenshell.geom.iterator(settings, model, 1, include=with_body)
        if iterator.initialize():
            while True:
                shape = iterator.get()
                verts = np.asarray(shape.geometry.verts, dtype=float).reshape(-1, 3)  # metres
                triangles = np.asarray(shape.geometry.faces, dtype=np.int64).reshape(-1, 3)
                zone = zone_of[shape.id]
                far = _beyond_bound(verts)
                if far is not None:  # a garbled placement or point: the schema would refuse the file naming an index
                    skipped.append({"line": None, "object": label[shape.id], "reason": far})
                    garbled.add(shape.id)
                elif len(triangles):
                    shaped.add(shape.id)
                    vertices.append(verts)
                    faces.extend({"id": f"{zone} t{k + 1}", "loops": [(t + offset).tolist()], "zones": [zone]}
                                 for k, t in enumerate(triangles))
                    offset += len(verts)
                if not iterator.next():
                    break
    for s in with_body:
        if s.id() not in shaped | garbled:
            skipped.append({"line": None, "object": label[s.id()],
                            "reason": "IfcOpenShell's geometry kernel made no triangles of its representation"})
    if not faces:
        # a space's body garbled is the likelier cause than a space without one (a room-less placeholder)
        ranked = sorted(skipped, key=lambda entry: entry["reason"] == "no representation")
        said = "; ".join(f"{entry['object']}: {entry['reason']}" for entry in ranked[:3])
        more = f"; and {len(ranked) - 3} more" if len(ranked) > 3 else ""
        unread = f" ({left_out.message})" if left_out is not None else ""
        raise reject(f"no usable IfcSpace: {said}{more}{was_cut}{unread}", ("file", ranked[0]["object"]))
    area_scale = ifcopenshell.util.unit.calculate_unit_scale(model, "AREAUNIT")
    volume_scale = ifcopenshell.util.unit.calculate_unit_scale(model, "VOLUMEUNIT")
    declared: dict[str, dict] = {}
    quantities_used: dict[str, dict] = {}
    unreadable = []
    for s in spaces:
        if s.id() not in shaped:
            continue
        try:
            sets = ifcopenshell.util.element.get_psets(s, qtos_only=True)
        except (AttributeError, RuntimeError, TypeError):  # a relation naming an entity the file lacks (damaged, cut)
            unreadable.append(label[s.id()])
            continue
        # IFC2X3 exporters (Revit, ArchiCAD) name the set "BaseQuantities"
        qto = sets.get("Qto_SpaceBaseQuantities") or sets.get("BaseQuantities") or {}
        volume = _quantity(qto, "NetVolume", "GrossVolume")
        floor = _quantity(qto, "NetFloorArea", "GrossFloorArea")
        entry, used = {}, {}
        if volume:
            entry["volume"], used["volume"] = volume[1] * _scale(model, qto, volume[0], volume_scale), volume[0]
        if floor:
            entry["floor_area"], used["floor_area"] = floor[1] * _scale(model, qto, floor[0], area_scale), floor[0]
        if entry:
            declared[zone_of[s.id()]], quantities_used[zone_of[s.id()]] = entry, used
    if unreadable:
        warnings.append(Diagnostic(code="ifc_quantities_unreadable", message=(
            f"The property sets of {len(unreadable)} space(s) cannot be read (they refer to entities the file does "
            f"not hold): their declared quantities were not compared, first {unreadable[0]}."),
            details={"spaces": unreadable[:MAX_SKIPPED_LISTED]}).model_dump())
    length_scale = project_length_scale(model, VOLUMES_DEPEND)
    length = ifcopenshell.util.unit.get_project_unit(model, "LENGTHUNIT")
    length_name = ifcopenshell.util.unit.get_full_unit_name(length) if length is not None else "none assigned: metres"
    spaces_listed = {zone_of[s.id()]: {"global_id": s.GlobalId, "name": s.Name, "long_name": s.LongName}
                     for s in spaces if s.id() in shaped}
    # a DATA section cut open: the totals are those of the spaces read, not the building's (a file missing only (part
    # of) its trailer after 'ENDSEC;' holds every instance)
    read_to_cut = {"read_to_cut": {
        "format": "IFC", "line": cut_line, "spaces_named": len(spaces), "spaces_measured": len(shaped),
        "spaces_not_measured": [label[s.id()] for s in spaces if s.id() not in shaped][:MAX_SKIPPED_LISTED],
        "objects_past_cut": aggregated_past_cut(blanked, model)}} if cut and not whole else {}
    return {"units": "m", "vertices": np.concatenate(vertices).tolist(), "faces": faces,
            "source": {"format": "ifc", "schema": model.schema,
                       "units": stated(symbol(length_scale), length_scale,
                                       "IfcUnitAssignment" if length is not None else NONE_ASSIGNED,
                                       f"the IFC project's length unit, {length_name}"), "faces": len(faces), "zones": len(shaped),
                       "spaces": spaces_listed, "declared": declared, "declared_quantities": quantities_used,
                       "skipped": skipped[:MAX_SKIPPED_LISTED], "skipped_count": len(skipped), **read_to_cut,
                       "warnings": warnings}}
