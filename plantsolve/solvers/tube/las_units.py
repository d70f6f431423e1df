"""The length unit a LAS/LAZ file states for its coordinates: the linear unit of its CRS.

Read from the OGC WKT coordinate system record (VLR or EVLR; WKT1 ``UNIT`` or WKT2 ``LENGTHUNIT``, whose second
value is the unit's length in metres, so any unit is understood) or else from the GeoTIFF keys
(ProjLinearUnitsGeoKey 3076, VerticalUnitsGeoKey 4099, by EPSG unit code). A vertical unit other than the
horizontal one is kept apart, for z. The WKT is read here rather than through pyproj (laspy's ``parse_crs``)
because only the unit is needed, and pyproj with its PROJ database is a large dependency for one number."""

from __future__ import annotations

import re
from dataclasses import dataclass

from plantsolve.solvers.length_units import unit_of_size

US_SURVEY_FOOT_M = 1200.0 / 3937.0
# EPSG unit-of-measure codes a GeoTIFF key may hold, with their length in metres
EPSG_LENGTH_UNITS = {9001: ("metre", 1.0), 9002: ("foot", 0.3048), 9003: ("US survey foot", US_SURVEY_FOOT_M),
                     1025: ("millimetre", 0.001), 1033: ("centimetre", 0.01), 9036: ("kilometre", 1000.0)}
PROJ_LINEAR_UNITS_KEY, VERTICAL_UNITS_KEY, MODEL_TYPE_KEY = 3076, 4099, 1024
MODEL_TYPE_GEOGRAPHIC = 2


@dataclass(frozen=True)
class CrsUnit:
    """The unit of x, y (``name``, ``metres`` per unit) and of z when the CRS states another; ``geographic`` when
    x, y are angles (a geographic CRS), which no pipe scan is in."""

    name: str
    metres: float
    evidence: str
    z_name: str | None = None
    z_metres: float | None = None
    geographic: bool = False


def short_name(name: str, metres: float) -> str:
    """The name the service uses for a length a CRS states: a request unit's, 'us_ft' for the US survey foot (a
    CRS's own unit, no request's), else the CRS's name."""
    if abs(metres - US_SURVEY_FOOT_M) <= 1e-9 * US_SURVEY_FOOT_M:
        return "us_ft"
    return unit_of_size(metres) or name


# ---- WKT -----------------------------------------------------------------------------------------------------------

_TOKEN = re.compile(r'\s*(?:("(?:[^"]|"")*")|([\[\](),])|([^\s\[\](),"]+))')
_PROJECTED = {"PROJCS", "PROJCRS", "PROJECTEDCRS", "GEOCCS", "LOCAL_CS", "ENGCRS", "ENGINEERINGCRS", "GEODCRS",
              "GEODETICCRS"}
_VERTICAL = {"VERT_CS", "VERTCRS", "VERTICALCRS"}
_GEOGRAPHIC = {"GEOGCS", "GEOGCRS", "GEOGRAPHICCRS"}
_COMPOUND = {"COMPD_CS", "COMPOUNDCRS"}
_UNITS = {"UNIT", "LENGTHUNIT", "ANGLEUNIT"}


def _parse_wkt(text: str) -> list:
    """WKT as nested lists ``[KEYWORD, arg, ...]``; strings keep their quotes off, numbers stay text."""
    pos, stack, root = 0, [[None]], None
    text = text.strip().rstrip("\x00")
    while pos < len(text):
        m = _TOKEN.match(text, pos)
        if not m or m.end() == pos:
            raise ValueError(f"unreadable WKT near {text[pos:pos + 20]!r}")
        pos = m.end()
        quoted, punct, word = m.groups()
        if quoted is not None:
            stack[-1].append(quoted[1:-1].replace('""', '"'))
        elif word is not None:
            stack[-1].append(word)
        elif punct in "[(":
            if len(stack[-1]) < 2 or not isinstance(stack[-1][-1], str):
                raise ValueError("WKT bracket without a keyword")
            node = [stack[-1].pop()]
            stack[-1].append(node)
            stack.append(node)
        elif punct in "])":
            if len(stack) < 2:
                raise ValueError("unbalanced WKT brackets")
            stack.pop()
    if len(stack) != 1 or len(stack[0]) != 2 or not isinstance(stack[0][1], list):
        raise ValueError("WKT is not one bracketed CRS")
    root = stack[0][1]
    return root


def _children(node: list, keywords: set[str]) -> list[list]:
    return [c for c in node[1:] if isinstance(c, list) and c[0].upper() in keywords]


def _node_unit(node: list) -> tuple[str, float, str] | None:
    """A CRS node's own length unit: its direct UNIT/LENGTHUNIT, else the first of its axes' (WKT2)."""
    units = _children(node, _UNITS)
    for axis in _children(node, {"AXIS"}) if not units else []:
        units = _children(axis, _UNITS)
        if units:
            break
    if not units:
        return None
    u = units[0]
    kind = "angle" if u[0].upper() == "ANGLEUNIT" else "length"
    return str(u[1]), float(u[2]), kind


def wkt_unit(text: str) -> CrsUnit | None:
    """The unit of a CRS in WKT (1 or 2); None when it states none. ValueError when the WKT cannot be read."""
    root = _parse_wkt(text)
    key = root[0].upper()
    horizontal, vertical = root, None
    if key in _COMPOUND:
        parts = _children(root, _PROJECTED | _GEOGRAPHIC | _VERTICAL)
        horizontal = next((p for p in parts if p[0].upper() not in _VERTICAL), None)
        vertical = next((p for p in parts if p[0].upper() in _VERTICAL), None)
    h = _node_unit(horizontal) if horizontal is not None else None
    v = _node_unit(vertical) if vertical is not None else None
    if horizontal is not None and horizontal[0].upper() in _VERTICAL:  # a vertical CRS alone
        h, v = None, _node_unit(horizontal)
    geographic = horizontal is not None and (horizontal[0].upper() in _GEOGRAPHIC or (h is not None and h[2] == "angle"))
    if h is None and v is None:
        return CrsUnit("", 0.0, "WKT", geographic=True) if geographic else None
    name, metres = (h[0], h[1]) if h and h[2] == "length" else (v[0], v[1]) if v else ("", 0.0)
    evidence = f'WKT UNIT["{name}", {metres:g}]'
    z_name = z_metres = None
    if v is not None and h is not None and v[2] == "length" and abs(v[1] - metres) > 1e-12 * metres:
        z_name, z_metres = v[0], v[1]
        evidence += f', vertical UNIT["{z_name}", {z_metres:g}]'
    return CrsUnit(name, metres, evidence, z_name, z_metres, geographic=geographic)


# ---- LAS -----------------------------------------------------------------------------------------------------------

def las_crs_unit(las) -> CrsUnit | None:
    """The unit the CRS records of a ``laspy.LasData`` state (WKT first, then GeoTIFF keys); None when none does.
    ValueError with the reason when a record states a unit that cannot be understood."""
    from laspy.vlrs.known import GeoKeyDirectoryVlr, WktCoordinateSystemVlr

    records = list(las.header.vlrs) + list(getattr(las, "evlrs", None) or [])
    for rec in records:
        if isinstance(rec, WktCoordinateSystemVlr) and rec.string.strip("\x00 \n"):
            unit = wkt_unit(rec.string)
            if unit is not None:
                return unit
    for rec in records:
        if isinstance(rec, GeoKeyDirectoryVlr):
            keys = {k.id: k.value_offset for k in rec.geo_keys if k.tiff_tag_location == 0}
            return _geokeys_unit(keys)
    return None


def _geokeys_unit(keys: dict[int, int]) -> CrsUnit | None:
    h, v = keys.get(PROJ_LINEAR_UNITS_KEY), keys.get(VERTICAL_UNITS_KEY)
    if h is None and keys.get(MODEL_TYPE_KEY) == MODEL_TYPE_GEOGRAPHIC:
        return CrsUnit("", 0.0, f"GeoTIFF GTModelTypeGeoKey {MODEL_TYPE_GEOGRAPHIC} (geographic)", geographic=True)
    for code in (h, v):
        if code is not None and code not in EPSG_LENGTH_UNITS:
            raise ValueError(f"GeoTIFF unit code {code} is not a length unit this reader knows "
                             f"({', '.join(map(str, EPSG_LENGTH_UNITS))})")
    if h is None and v is None:
        return None
    code = h if h is not None else v
    name, metres = EPSG_LENGTH_UNITS[code]
    evidence = f"GeoTIFF {'ProjLinearUnitsGeoKey' if h is not None else 'VerticalUnitsGeoKey'} {code}"
    z_name = z_metres = None
    if h is not None and v is not None and v != h:
        z_name, z_metres = EPSG_LENGTH_UNITS[v]
        evidence += f", VerticalUnitsGeoKey {v}"
    return CrsUnit(name, metres, evidence, z_name, z_metres)
