"""gbXML (as Revit, OpenStudio and the gbXML test cases write it) as a polyhedra request.

Faces come from ``Campus/Surface``: its ``PlanarGeometry/PolyLoop`` of ``CartesianPoint/Coordinate``
triples, counter-clockwise seen from outside its first ``AdjacentSpaceId`` (a second one makes it the
wall between two spaces, written once; the same space twice, as Revit writes a slab on grade, is one); each ``Opening``'s PolyLoop is a subsurface of its surface.
A ``RectangularGeometry`` its polygon contradicts is named (:mod:`.gbxml_rectangles`); the polygon is measured.
A space no surface names is read from its own ``ShellGeometry/ClosedShell`` PolyLoops (in ``lengthUnit``; a shell whose
own ``unit`` says otherwise is named, ``shell_unit_differs``). Zones are named
by the space's ``id`` (its ``Name`` is listed in ``source.spaces``). A surface without an adjacent space
(``Shade``) bounds no zone and is skipped, like anything else that cannot be read, with its line and
reason.

Units: coordinates are converted to metres from the root's ``lengthUnit`` (the schema's default,
Meters, when absent; ``source.units`` says so, and :mod:`.file_units` goes on to the request's unit); the file's own ``Space/Volume``
and ``Space/Area`` (floor area), converted from ``volumeUnit`` and ``areaUnit``, are kept in
``source.declared`` for the solver to compare with what it measures.

The XML is read by the standard library's expat parser (no lxml or defusedxml here); a file with a
DOCTYPE or an entity declaration (which gbXML never has, and which is the way in for entity expansion)
is refused.
"""

from __future__ import annotations

import codecs
import math
import re
import xml.etree.ElementTree as ET
from typing import Any
from xml.parsers import expat

from plantsolve.schemas.common import Diagnostic
from plantsolve.schemas.polyhedra import MAX_COORDINATE
from plantsolve.solvers.base import reject
from plantsolve.solvers.polyhedra.file_units import stated, symbol
from plantsolve.solvers.polyhedra.gbxml_rectangles import differs, rectangles_differ

MAX_SKIPPED_LISTED = 200
LENGTH = {"meters": 1.0, "centimeters": 0.01, "millimeters": 0.001, "kilometers": 1000.0, "feet": 0.3048,
          "inches": 0.0254, "yards": 0.9144, "miles": 1609.344}
AREA = {"squaremeters": 1.0, "squarecentimeters": 1e-4, "squaremillimeters": 1e-6, "squarekilometers": 1e6,
        "squarefeet": 0.09290304, "squareinches": 0.00064516, "squareyards": 0.83612736,
        "squaremiles": 2589988.110336}
VOLUME = {"cubicmeters": 1.0, "cubiccentimeters": 1e-6, "cubicmillimeters": 1e-9, "cubickilometers": 1e9,
          "cubicfeet": 0.028316846592, "cubicinches": 1.6387064e-5, "cubicyards": 0.764554857984,
          "cubicmiles": 4168181825.440579}


def _local(tag: Any) -> str:
    return tag.rsplit("}", 1)[-1] if isinstance(tag, str) else ""


def _children(element: ET.Element, name: str) -> list[ET.Element]:
    return [c for c in element if _local(c.tag) == name]


def _child(element: ET.Element, name: str) -> ET.Element | None:
    found = _children(element, name)
    return found[0] if found else None


def _unit(root: ET.Element, attribute: str, table: dict[str, float], default: str) -> tuple[str, float | None]:
    name = (root.get(attribute) or default).strip()
    return name, table.get(name.lower())


def _polyloop(loop: ET.Element, scale: float) -> list[list[float]]:
    points = []
    for k, point in enumerate(_children(loop, "CartesianPoint"), 1):
        coordinates = _children(point, "Coordinate")
        if len(coordinates) != 3:
            raise ValueError(f"CartesianPoint {k} has {len(coordinates)} Coordinate(s), not 3")
        try:
            xyz = [float((c.text or "").strip()) * scale for c in coordinates]
        except ValueError:
            raise ValueError(f"CartesianPoint {k}: {[c.text for c in coordinates]} are not numbers") from None
        if not all(math.isfinite(v) for v in xyz):
            raise ValueError(f"CartesianPoint {k} is not finite")
        if any(abs(v) > MAX_COORDINATE for v in xyz):  # the schema's refusal would name a face index, not the line
            raise ValueError(f"CartesianPoint {k} is beyond ±{MAX_COORDINATE:g} m")
        points.append(xyz)
    if len({tuple(p) for p in points}) < 3:
        raise ValueError(f"{len({tuple(p) for p in points})} distinct points; a face needs at least 3")
    return points


def _planar(element: ET.Element, scale: float) -> list[list[float]]:
    planar = _child(element, "PlanarGeometry")
    loop = _child(planar, "PolyLoop") if planar is not None else None
    if loop is None:
        raise ValueError("no PlanarGeometry/PolyLoop" + (" (only RectangularGeometry)"
                                                          if _child(element, "RectangularGeometry") is not None else ""))
    return _polyloop(loop, scale)


def _say_shell_unit(shell: ET.Element, length_name: str, lines: dict[int, int], warnings: list[dict]) -> None:
    """The warning for a ``ShellGeometry`` whose own ``unit`` is not the file's ``lengthUnit``: the file contradicts
    itself, and which of the two is right only its writer knows. The shell is read in ``lengthUnit``, as the surfaces
    are, so that every zone of the building is measured in one unit and the plausibility checks see one building (a
    lengthUnit of Feet over metres is named there); before, the shell's unit went unread and unsaid."""
    own = (shell.get("unit") or "").strip()
    if not own or own.lower() == length_name.lower():
        return
    line = lines.get(id(shell))
    factor = LENGTH.get(own.lower())
    ratio = (f" (read in {own}, its space's volume would be {(factor / LENGTH[length_name.lower()]) ** 3:.4g} times "
             "as large)") if factor is not None and length_name.lower() in LENGTH else ""
    warnings.append(Diagnostic(code="shell_unit_differs", message=(
        f"The ShellGeometry on line {line} states its unit {own!r}, the file's lengthUnit is {length_name!r}: the "
        f"file contradicts itself. Its coordinates were read in {length_name}, as the surfaces are{ratio}."),
        details={"line": line, "unit": own, "lengthUnit": length_name}).model_dump())


def _id_and_label(element: ET.Element, tag: str) -> tuple[str, str]:
    """The element's ``id`` (blank when it has none) and the label a skipped-object entry names it by."""
    eid = (element.get("id") or "").strip()
    return eid, f"{tag} {eid!r}" if eid else tag


def _declared(space: ET.Element, name: str, factor: float | None) -> float | None:
    node = _child(space, name)
    if node is None or factor is None:
        return None
    try:
        value = float((node.text or "").strip()) * factor
    except ValueError:
        return None
    return value if math.isfinite(value) and value > 0 else None


class _Doctype(Exception):
    pass


def _refuse_doctype(*_args: Any) -> None:
    raise _Doctype


def _parse(content: bytes) -> tuple[ET.Element, dict[int, int]]:
    """The document as an ElementTree, and the line each element starts on (by the element's id)."""
    builder = ET.TreeBuilder()
    lines: dict[int, int] = {}
    parser = expat.ParserCreate(namespace_separator="}")

    def start(tag: str, attrs: dict[str, str]) -> None:
        lines[id(builder.start(tag, attrs))] = parser.CurrentLineNumber

    parser.StartElementHandler = start
    parser.EndElementHandler = builder.end
    parser.CharacterDataHandler = builder.data
    parser.StartDoctypeDeclHandler = _refuse_doctype
    parser.EntityDeclHandler = _refuse_doctype
    try:
        parser.Parse(content, True)
    except _Doctype:
        raise reject("the XML file has a DOCTYPE or ENTITY declaration; gbXML has none, and it is not read",
                     ("file", "line", parser.CurrentLineNumber)) from None
    except expat.ExpatError as e:
        last = content.rstrip().count(b"\n") + 1
        if e.lineno >= last and e.code in (expat.errors.codes[expat.errors.XML_ERROR_NO_ELEMENTS],
                                           expat.errors.codes[expat.errors.XML_ERROR_UNCLOSED_TOKEN],
                                           expat.errors.codes[expat.errors.XML_ERROR_PARTIAL_CHAR]):
            raise reject(f"the XML ends before its document is complete (line {e.lineno}, column {e.offset}: "
                         f"{expat.ErrorString(e.code)}): the file was cut? Nothing of a cut gbXML is used",
                         ("file", "line", e.lineno)) from None
        raise reject(f"not well-formed XML: {expat.ErrorString(e.code)} (line {e.lineno}, column {e.offset})",
                     ("file", "line", e.lineno)) from None
    return builder.close(), lines


_DECLARED_ENCODING = re.compile(rb"^(<\?xml[^>]*?)\sencoding\s*=\s*(['\"])[^'\"]*\2")


def _utf16_as_utf8(content: bytes) -> bytes:
    """A file with a UTF-16 byte-order mark as UTF-8, its declaration's encoding dropped: an editor that saves as
    'Unicode' keeps the declaration's encoding="utf-8", which expat refuses against the mark (and the mark is what
    the bytes are). Other content as it is."""
    if content[:2] not in (codecs.BOM_UTF16_LE, codecs.BOM_UTF16_BE):
        return content
    try:
        text = content.decode("utf-16").encode("utf-8")
    except UnicodeDecodeError:
        return content
    return _DECLARED_ENCODING.sub(rb"\1", text, count=1)


_ENCODING = re.compile(rb"^(?:\xef\xbb\xbf)?\s*<\?xml[^>]*?\sencoding\s*=\s*(['\"])([^'\"]*)\1")


def _windows_text_as_utf8(content: bytes) -> tuple[bytes, Diagnostic | None]:
    """A file that says (or, saying nothing, means) UTF-8 but is not, as UTF-8 read from Windows-1252, with a warning
    naming the encoding; other content as it is. Windows tools save a room name 'Büro' as the byte 0xFC under
    encoding="utf-8", which expat refuses as an 'invalid token'; only names and text differ, not a number."""
    declared = _ENCODING.match(content)
    name = declared.group(2).decode("ascii", "replace").strip().lower() if declared else "utf-8"
    if name.replace("-", "").replace("_", "") != "utf8" or content[:2] in (codecs.BOM_UTF16_LE, codecs.BOM_UTF16_BE):
        return content, None
    try:
        content.decode("utf-8")
        return content, None
    except UnicodeDecodeError as e:
        bad = e.start
    line = content.count(b"\n", 0, bad) + 1
    text = content.removeprefix(codecs.BOM_UTF8).decode("cp1252", errors="replace").encode("utf-8")
    return _DECLARED_ENCODING.sub(rb"\1", text, count=1), Diagnostic(code="encoding_assumed", message=(
        f"The file says {'encoding=' + repr(name) if declared else 'nothing of its encoding (XML then means UTF-8)'}"
        f" but is not UTF-8 (byte 0x{content[bad]:02X} on line {line}): it was read as Windows-1252, as Windows "
        "tools write it. Only names and text are affected; check the names of spaces in the result."),
        details={"declared": name, "read_as": "cp1252", "line": line})


def parse_gbxml(content: bytes) -> dict:
    content, misdeclared = _windows_text_as_utf8(content)
    root, lines = _parse(_utf16_as_utf8(content))
    if _local(root.tag) != "gbXML":
        raise reject(f"the XML file's root element is {_local(root.tag)!r}, not gbXML")
    warnings: list[dict] = [misdeclared.model_dump()] if misdeclared is not None else []
    skipped: list[dict] = []
    length_name, scale = _unit(root, "lengthUnit", LENGTH, "Meters")
    if scale is None:
        raise reject(f"lengthUnit {length_name!r} is not a gbXML length unit ({', '.join(LENGTH)})",
                     ("file", "line", lines.get(id(root), 1)))
    area_name, area_factor = _unit(root, "areaUnit", AREA, "SquareMeters")
    volume_name, volume_factor = _unit(root, "volumeUnit", VOLUME, "CubicMeters")
    for label, name, factor in (("areaUnit", area_name, area_factor), ("volumeUnit", volume_name, volume_factor)):
        if factor is None:
            warnings.append(Diagnostic(code="unknown_unit", message=(
                f"The file's {label} {name!r} is not a gbXML unit: its declared space measures are not compared."),
                details={label: name}).model_dump())

    def skip(element: ET.Element, label: str, reason: str) -> None:
        skipped.append({"line": lines.get(id(element)), "object": label, "reason": reason})

    campuses = _children(root, "Campus")
    spaces: dict[str, ET.Element] = {}
    for campus in campuses:
        for building in _children(campus, "Building"):
            for space in (e for e in building.iter() if _local(e.tag) == "Space"):
                sid, label = _id_and_label(space, "Space")
                if not sid:
                    skip(space, label, "no id")
                elif sid in spaces:
                    skip(space, label, f"a space of this id is already on line {lines.get(id(spaces[sid]))}")
                else:
                    spaces[sid] = space

    faces: list[dict] = []
    face_line: dict[str, int | None] = {}

    def add(face: dict, element: ET.Element, label: str) -> None:
        if face["id"] in face_line:
            skip(element, label, f"a surface of this id is already on line {face_line[face['id']]}")
            return
        faces.append(face)
        face_line[face["id"]] = lines.get(id(element))

    bounded: set[str] = set()
    contradicted: list[tuple[str, int | None, str]] = []
    for campus in campuses:
        for surface in _children(campus, "Surface"):
            sid, label = _id_and_label(surface, "Surface")
            try:
                if not sid:
                    raise ValueError("no id")
                adjacent = [(a.get("spaceIdRef") or "").strip() for a in _children(surface, "AdjacentSpaceId")]
                adjacent = [a for a in adjacent if a]
                if not adjacent:
                    raise ValueError(f"no AdjacentSpaceId (a {surface.get('surfaceType') or 'surface'} bounding no "
                                     "space)")
                if len(adjacent) > 2:
                    raise ValueError(f"{len(adjacent)} AdjacentSpaceIds; a surface has one or two")
                if len(adjacent) == 2 and adjacent[0] == adjacent[1]:
                    adjacent = adjacent[:1]  # Revit writes a slab on grade's one space twice
                unknown = [a for a in adjacent if spaces and a not in spaces]
                if unknown:
                    raise ValueError(f"AdjacentSpaceId {unknown[0]!r} names no Space of the file")
                points = _planar(surface, scale)
            except ValueError as e:
                skip(surface, label, str(e))
                continue
            before = len(faces)
            add({"id": sid, "loops": [points], "zones": adjacent}, surface, label)
            if len(faces) == before:
                continue
            why = differs(surface, points, scale, _child)
            if why is not None:
                contradicted.append((sid, lines.get(id(surface)), why))
            bounded.update(adjacent)
            for opening in _children(surface, "Opening"):
                oid, olabel = _id_and_label(opening, "Opening")
                try:
                    if not oid:
                        raise ValueError("no id")
                    opoints = _planar(opening, scale)
                except ValueError as e:
                    skip(opening, olabel, str(e))
                    continue
                add({"id": oid, "loops": [opoints], "parent": sid}, opening, olabel)
                why = differs(opening, opoints, scale, _child)
                if why is not None:
                    contradicted.append((oid, lines.get(id(opening)), why))

    for sid, space in spaces.items():
        if sid in bounded:
            continue
        shell = _child(space, "ShellGeometry")
        closed = _child(shell, "ClosedShell") if shell is not None else None
        if closed is None:
            skip(space, f"Space {sid!r}", "no Surface names it and it has no ShellGeometry/ClosedShell")
            continue
        _say_shell_unit(shell, length_name, lines, warnings)
        for k, loop in enumerate(_children(closed, "PolyLoop"), 1):
            label = f"Space {sid!r} ClosedShell PolyLoop {k}"
            try:
                points = _polyloop(loop, scale)
            except ValueError as e:
                skip(loop, label, str(e))
                continue
            add({"id": f"{sid} shell {k}", "loops": [points], "zones": [sid]}, loop, label)

    if not any("parent" not in f for f in faces):
        first = skipped[0] if skipped else None
        if first:
            where = ("file", "line", first["line"]) if first["line"] else ("file",)
            at = f" (line {first['line']})" if first["line"] else ""
            raise reject(f"no usable surface: {first['object']}{at}: {first['reason']}", where)
        raise reject("no Campus/Surface with a PlanarGeometry and no Space with a ShellGeometry in this gbXML file")

    contradiction = rectangles_differ(contradicted)
    if contradiction is not None:
        warnings.append(contradiction.model_dump())
    names = {sid: ((_child(s, "Name").text or "").strip() if _child(s, "Name") is not None else "")
             for sid, s in spaces.items()}
    declared = {}
    for sid, space in spaces.items():
        entry = {k: v for k, v in (("volume", _declared(space, "Volume", volume_factor)),
                                   ("floor_area", _declared(space, "Area", area_factor))) if v is not None}
        if entry:
            declared[sid] = entry
    zones = {z for f in faces for z in f.get("zones", [])}
    return {"units": "m", "faces": faces,
            "source": {"format": "gbxml", "faces": len(faces), "zones": len(zones),
                       "units": stated(symbol(scale), scale, "lengthUnit", f"gbXML lengthUnit={length_name!r}",
                                       lengthUnit=length_name, areaUnit=area_name, volumeUnit=volume_name),
                       "spaces": {sid: names[sid] for sid in spaces if sid in zones},
                       "declared": {sid: v for sid, v in declared.items() if sid in zones},
                       "skipped": skipped[:MAX_SKIPPED_LISTED], "skipped_count": len(skipped), "warnings": warnings}}
