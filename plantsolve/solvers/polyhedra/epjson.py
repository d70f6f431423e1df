"""EnergyPlus' epJSON: the IDF's objects as JSON, keyed by object type, then by name.

Each object's fields are named as in EnergyPlus' ``Energy+.schema.epJSON`` (``zone_name``,
``starting_x_coordinate``, …); the extensible vertex list of the ``*:Detailed`` surfaces is
``vertices: [{vertex_x_coordinate, vertex_y_coordinate, vertex_z_coordinate}, …]``, while
``FenestrationSurface:Detailed`` has fixed ``vertex_1_x_coordinate`` … ``vertex_4_z_coordinate``.
The objects are laid out as IDF fields in the IDD's order and read by the IDF reader, so an IDF and
its epJSON twin give the same request. Fields EnergyPlus' converter adds (``idf_order``,
``idf_max_fields``, …) and object types the reader does not use are ignored.
"""

from __future__ import annotations

import json
import math
from typing import Any

from plantsolve.solvers.base import json_object

# type -> its fields after the name, in the IDD's order ("vertices": the extensible vertex list)
_DETAILED = ("construction_name", "zone_name", "space_name", "outside_boundary_condition",
             "outside_boundary_condition_object", "sun_exposure", "wind_exposure", "view_factor_to_ground",
             "number_of_vertices", "vertices")
_RECTANGLE = ("azimuth_angle", "tilt_angle", "starting_x_coordinate", "starting_y_coordinate",
              "starting_z_coordinate", "length")
_SUB = ("starting_x_coordinate", "starting_z_coordinate", "length", "height")
_WINDOW = ("construction_name", "building_surface_name", "frame_and_divider_name", "multiplier", *_SUB)
_INTERZONE_SUB = ("construction_name", "building_surface_name", "outside_boundary_condition_object", "multiplier",
                  *_SUB)
FIELDS: dict[str, tuple[str, ...]] = {
    "zone": ("direction_of_relative_north", "x_origin", "y_origin", "z_origin", "type", "multiplier",
             "ceiling_height", "volume", "floor_area", "zone_inside_convection_algorithm",
             "zone_outside_convection_algorithm", "part_of_total_floor_area"),
    "buildingsurface:detailed": ("surface_type", *_DETAILED),
    "wall:detailed": _DETAILED,
    "roofceiling:detailed": _DETAILED,
    "floor:detailed": _DETAILED,
    "fenestrationsurface:detailed": (
        "surface_type", "construction_name", "building_surface_name", "outside_boundary_condition_object",
        "view_factor_to_ground", "frame_and_divider_name", "multiplier", "number_of_vertices",
        *(f"vertex_{k}_{axis}_coordinate" for k in range(1, 5) for axis in "xyz")),
    **{cls: ("construction_name", "zone_name", "space_name", *_RECTANGLE, "height")
       for cls in ("wall:exterior", "wall:adiabatic", "wall:underground")},
    "wall:interzone": ("construction_name", "zone_name", "space_name", "outside_boundary_condition_object",
                       *_RECTANGLE, "height"),
    **{cls: ("construction_name", "zone_name", "space_name", *_RECTANGLE, "width")
       for cls in ("roof", "ceiling:adiabatic", "floor:groundcontact", "floor:adiabatic")},
    **{cls: ("construction_name", "zone_name", "space_name", "outside_boundary_condition_object", *_RECTANGLE,
             "width") for cls in ("ceiling:interzone", "floor:interzone")},
    "zonelist": ("zones",),
    "zonegroup": ("zone_list_name", "zone_list_multiplier"),
    "space": ("zone_name", "ceiling_height", "volume", "floor_area"),
    "window": _WINDOW,
    "glazeddoor": _WINDOW,
    "door": ("construction_name", "building_surface_name", "multiplier", *_SUB),
    "window:interzone": _INTERZONE_SUB,
    "door:interzone": _INTERZONE_SUB,
    "glazeddoor:interzone": _INTERZONE_SUB,
}
UNNAMED = {  # unique objects without a name field: the JSON key is not a field
    "globalgeometryrules": ("starting_vertex_position", "vertex_entry_direction", "coordinate_system",
                            "daylighting_reference_point_coordinate_system", "rectangular_surface_coordinate_system"),
}
# Yes/No choices: a JSON true or false there means the choice (a writer's own encoding; EnergyPlus' schema spells
# "Yes"/"No"), not a field to drop the whole object over
YES_NO = {"part_of_total_floor_area"}
VERTEX_KEYS = ("vertex_x_coordinate", "vertex_y_coordinate", "vertex_z_coordinate")
EXTENSIBLE = {"vertices": ("vertex", VERTEX_KEYS), "zones": ("zone", ("zone_name",))}  # lists of field groups


def _text(value: Any) -> str:
    """A field as the IDF would write it (numbers exactly: repr of a float round-trips)."""
    if value is None:
        return ""
    if isinstance(value, bool):
        raise ValueError(f"{value!r} is not a number or a name")
    if isinstance(value, float):
        return repr(value) if math.isfinite(value) else str(value)
    if isinstance(value, (int, str)):
        return str(value)
    raise ValueError(f"{json.dumps(value)[:60]} is not a number or a name")


def _fields(cls: str, name: str, body: dict) -> list[str]:
    keys = UNNAMED.get(cls) or FIELDS[cls]
    fields = [] if cls in UNNAMED else [name]
    for key in keys:
        if key not in EXTENSIBLE:
            value = body.get(key)
            if key in YES_NO and isinstance(value, bool):
                fields.append("Yes" if value else "No")
                continue
            try:
                fields.append(_text(value))
            except ValueError as e:
                raise ValueError(f"{key}: {e}") from None
            continue
        item, item_keys = EXTENSIBLE[key]
        entries = body.get(key, [])
        if not isinstance(entries, list):
            raise ValueError(f"{key!r} is not a list")
        for k, entry in enumerate(entries, 1):
            if not isinstance(entry, dict):
                raise ValueError(f"{item} {k} is not an object of {', '.join(item_keys)}")
            try:
                fields.extend(_text(entry.get(axis)) for axis in item_keys)
            except ValueError as e:
                raise ValueError(f"{item} {k}: {e}") from None
    return fields


def epjson_objects(text: str) -> tuple[list[tuple[str, list[str], list[int], None]], list[dict]]:
    """The objects the IDF reader uses, as (class, fields, field lines, line) with no lines; and the
    objects skipped (type and name, reason)."""
    document = json_object(text, "an epJSON file holds one object: object types, then names, then fields",
                           refuse_cut=True)
    objects, skipped = [], []
    for type_name, named in document.items():
        cls = type_name.lower()
        if cls not in FIELDS and cls not in UNNAMED:
            continue
        if not isinstance(named, dict):
            skipped.append({"line": None, "object": type_name, "reason": "not an object of named objects"})
            continue
        for name, body in named.items():
            label = f"{cls} {name!r}"
            try:
                if not isinstance(body, dict):
                    raise ValueError("its fields are not an object")
                fields = _fields(cls, name, body)
            except ValueError as e:
                skipped.append({"line": None, "object": label, "reason": str(e)})
                continue
            objects.append((cls, fields, [None] * len(fields), None))
    return objects, skipped
