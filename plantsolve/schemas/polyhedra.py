"""Request and result models of the ``polyhedra`` solver (zone volumes, areas and closure diagnostics).

Conventions
-----------
- Lengths are in the request's ``units`` (default ``"m"``); areas in units², volumes in units³.
- A face is one planar polygon with an outer loop and optional inner loops (holes). The outer loop
  runs counter-clockwise seen from outside the face's first zone; inner loops run the other way
  (the solver turns an inner loop that runs the same way as its outer loop and says so).
- A loop is a list of vertex indices into ``vertices`` or a list of ``[x, y, z]`` points.
- A face listed with two zones is the wall between them: it bounds both (with opposite
  orientation for the second zone). A face with a ``parent`` is a subsurface (window, door) of
  that face: it reduces the parent's net area and is not part of any enclosure.
"""

from __future__ import annotations

from typing import Annotated, Any, Literal

import numpy as np
from pydantic import BaseModel, BeforeValidator, Discriminator, Field, PlainSerializer, PlainValidator, Tag, \
    TypeAdapter, WithJsonSchema

from plantsolve.schemas.common import LENGTH, MAX_COORDINATE, FiniteFloat, Flag, Point3, Report, StrictModel, Units, \
    json_integer, plain_numbers, unit

MAX_VERTICES = 5_000_000
MAX_FACES = 2_000_000
MAX_LOOP = 100_000
MAX_LISTED_FACES = 10_000  # above this many faces a result lists them only when asked (list_faces)
FLOOR_CONE_DEG = 45.0  # a face whose outward normal is within this of straight down is floor
AREA, VOLUME = LENGTH + "^2", LENGTH + "^3"

Name = Annotated[str, Field(min_length=1, max_length=200)]
MAX_ZONE_MULTIPLIER = 1_000_000
# How many identical copies a named zone or subsurface stands for (EnergyPlus' Multiplier fields): whole, at least 1.
Multipliers = dict[Name, Annotated[int, Field(ge=1, le=MAX_ZONE_MULTIPLIER), BeforeValidator(json_integer)]]
VertexIndex = Annotated[int, Field(ge=0, lt=MAX_VERTICES), BeforeValidator(json_integer)]


def _loop_form(value: Any) -> str:
    """A loop of points starts with a list, a loop of indices with a number."""
    if isinstance(value, (list, tuple)) and value and isinstance(value[0], (list, tuple)):
        return "points"
    return "indices"


Loop = Annotated[
    Annotated[list[VertexIndex], Field(min_length=3, max_length=MAX_LOOP), Tag("indices")]
    | Annotated[list[Point3], Field(min_length=3, max_length=MAX_LOOP), Tag("points")],
    Discriminator(_loop_form),
]


class Face(StrictModel):
    """One polygon: an outer loop and its holes."""

    id: Name = Field(description="Face name, unique in the request (e.g. the IDF surface name).")
    loops: list[Loop] = Field(
        min_length=1, max_length=10_000,
        description="The outer loop first (counter-clockwise seen from outside the first zone), then inner "
        "loops (holes: shafts, courtyards). Each loop is vertex indices or [x, y, z] points (at least 3 distinct).")
    zones: list[Name] | None = Field(
        default=None, min_length=1, max_length=2,
        description="The zone(s) this face bounds: one, or two for a wall between zones (the loop is "
        "counter-clockwise seen from outside the first). Omitted: the zone 'default'.")
    parent: Name | None = Field(
        default=None,
        description="Id of the host face when this face is a subsurface (window, door): it reduces the host's "
        "net area and is not part of any enclosure.")


def _mesh_vertices(value: Any) -> np.ndarray:
    """(N, 3) finite float64 coordinates: an array as a reader made it, or JSON's ``[[x, y, z], ...]``."""
    if not isinstance(value, np.ndarray):
        value = _POINTS.validate_python(value, strict=True)
    array = np.asarray(value, dtype=np.float64).reshape(-1, 3) if np.size(value) else np.zeros((0, 3))
    if len(array) < 3:
        raise ValueError(f"a mesh needs at least 3 vertices, got {len(array)}")
    if len(array) > MAX_VERTICES:
        raise ValueError(f"at most {MAX_VERTICES} vertices, got {len(array)}")
    if not (array.min() >= -MAX_COORDINATE and array.max() <= MAX_COORDINATE):  # NaN fails both
        bad = ~(np.abs(array) <= MAX_COORDINATE).all(axis=1)
        raise ValueError(f"vertex {int(np.flatnonzero(bad)[0])} is not finite or beyond {MAX_COORDINATE:g}")
    return array


def _mesh_triangles(value: Any) -> np.ndarray:
    """(M, 3) int64 vertex indices: an array as a reader made it, or JSON's ``[[i, j, k], ...]``."""
    if not isinstance(value, np.ndarray):
        value = _TRIANGLES.validate_python(value, strict=True)
    array = np.asarray(value, dtype=np.int64).reshape(-1, 3) if np.size(value) else np.zeros((0, 3), np.int64)
    if not len(array):
        raise ValueError("a mesh needs at least one triangle")
    if len(array) > MAX_FACES:
        raise ValueError(f"at most {MAX_FACES} triangles, got {len(array)}")
    return array


_POINTS = TypeAdapter(list[Point3])
_TRIANGLES = TypeAdapter(list[Annotated[list[VertexIndex], Field(min_length=3, max_length=3)]])


def _array_schema(items: dict, least: int, bound: int, description: str) -> WithJsonSchema:
    return WithJsonSchema({"type": "array", "minItems": least, "maxItems": bound, "description": description,
                           "items": {"type": "array", "minItems": 3, "maxItems": 3, "items": items}})


MeshVertices = Annotated[
    Any, PlainValidator(_mesh_vertices), PlainSerializer(lambda a: a.tolist()),
    _array_schema({"type": "number", "minimum": -MAX_COORDINATE, "maximum": MAX_COORDINATE}, 3, MAX_VERTICES, "Vertex coordinates [x, y, z] (request units).")]
MeshTriangles = Annotated[
    Any, PlainValidator(_mesh_triangles), PlainSerializer(lambda a: a.tolist()),
    _array_schema({"type": "integer", "minimum": 0, "maximum": MAX_VERTICES - 1}, 1, MAX_FACES,
                  "Vertex indices [i, j, k] into the mesh's vertices, counter-clockwise seen from outside.")]


class TriangleMesh(StrictModel):
    """One zone's surface as a triangle mesh: two arrays instead of a face object per triangle."""

    zone: Name = Field(default="default", description="The zone the triangles bound.")
    vertices: MeshVertices
    triangles: MeshTriangles
    id_prefix: Annotated[str, Field(max_length=100)] = Field(
        default="t", description="Triangle k (from 0) is the face '<id_prefix><k + 1>' in results and reports.")


class PolyhedraOptions(StrictModel):
    _plain_numbers = plain_numbers("merge_tolerance", "planarity_tolerance")

    merge_tolerance: FiniteFloat = Field(
        default=1e-6, ge=0.0, le=100.0,
        description="Vertices closer than this (request units) are one vertex; also the distance within which a "
        "vertex lies on an edge (T-junction). Default 1e-6 m (in the request's units: 1e-3 for mm). At most 0.05 m "
        "in the request's units (checked at submission).")
    planarity_tolerance: FiniteFloat = Field(
        default=1e-4, ge=0.0, le=1e3,
        description="Largest distance (request units) of a face's vertex from the face's plane before the face "
        "is reported non-planar (EnergyPlus uses 1e-4 m). Default 1e-4 m (in the request's units: 0.1 for mm). "
        "At most 0.5 m in the request's units (checked at submission).")
    file_units: Units | None = Field(
        default=None,
        description="The length unit of the uploaded file's coordinates, overriding what the file states (a gbXML "
        "lengthUnit that contradicts its numbers) or saying what it does not (OBJ and STL state none: they are read "
        "in the request's units unless this is given). The numbers are converted to the request's units; "
        "report.details.source.units says how.")
    list_faces: Flag | None = Field(
        default=None,
        description=f"List every face in the result (faces, each zone's faces and misoriented faces): true always, "
        f"false never; omitted: when the request has at most {MAX_LISTED_FACES} faces. The zones.csv artifact "
        "lists them as faces_csv says.")
    faces_csv: Flag | None = Field(
        default=None,
        description=f"A row per face in the zones.csv artifact (area, net area, perimeter, normal, planarity error) "
        f"after the zone rows: true always, false never; omitted: when the request has at most {MAX_LISTED_FACES} "
        "faces (a million-triangle mesh's face rows are some 180 MB, written only when asked).")


class PolyhedraRequest(StrictModel):
    units: Units = Field(default="m", description="Length unit of vertices and of every result.")
    vertices: list[Point3] = Field(
        default_factory=list, max_length=MAX_VERTICES,
        description="Vertex coordinates [x, y, z] referenced by index from the loops.")
    faces: list[Face] = Field(default_factory=list, max_length=MAX_FACES,
                              description="The faces; may be empty when a mesh is given.")
    mesh: TriangleMesh | None = Field(
        default=None, description="A zone given as a triangle mesh (an STL upload is read into one); its triangles "
        "follow the faces.")
    options: PolyhedraOptions = Field(default_factory=PolyhedraOptions)
    zone_multipliers: Multipliers = Field(
        default_factory=dict, max_length=MAX_FACES,
        description="How many identical copies of a zone the building holds (EnergyPlus' Zone Multiplier times its "
        "ZoneGroup's Zone List Multiplier, read from an IDF or epJSON upload): total_volume and total_floor_area "
        "count the zone that many times, as EnergyPlus counts floor area; the zone's own measures are one copy's. "
        "Zones not named count once.")
    zones_outside_total_floor_area: list[Name] = Field(
        default_factory=list, max_length=MAX_FACES,
        description="Zones whose floor total_floor_area leaves out, as EnergyPlus leaves out a Zone whose Part of "
        "Total Floor Area is No (plenums, attics; read from an IDF or epJSON upload); their own floor_area is still "
        "given, and their volume still counts in total_volume.")
    subsurface_multipliers: Multipliers = Field(
        default_factory=dict, max_length=MAX_FACES,
        description="How many identical copies of a subsurface its host holds (EnergyPlus' Multiplier of a window, "
        "glass door or door, read from an IDF or epJSON upload): the host's net_area loses each copy's area, as "
        "EnergyPlus multiplies the subsurface's area; the subsurface's own area is one copy's. Subsurfaces not named "
        "count once.")
    source: dict[str, Any] | None = Field(
        default=None,
        description="What the upload parser read (file format, objects skipped with line and reason); set by the "
        "upload parser, not needed in JSON bodies.")


class EdgeReport(BaseModel):
    """An edge of a zone's surface that is not shared by exactly two faces."""

    start: Point3 = Field(description="One end [x, y, z] (request units).", json_schema_extra=unit(LENGTH))
    end: Point3 = Field(description="The other end [x, y, z] (request units).", json_schema_extra=unit(LENGTH))
    faces: list[str] = Field(description="Ids of the faces using this edge in this zone.")
    uses: int = Field(description="How many face boundaries run along the edge in this zone (2 when manifold).")


class ZoneResult(BaseModel):
    id: str
    volume: float | None = Field(
        description="Enclosed volume (units³), null unless the zone's surface is closed; faces turned the wrong "
        "way are counted the right way (they are listed in misoriented_faces).", json_schema_extra=unit(VOLUME))
    signed_volume: float = Field(
        description="Divergence-theorem volume (units³) with the faces as given: negative when inside out. Of an "
                    "open zone, the volume its faces bound with a cone from the zone's centre (the mean of its faces' "
                    "vertex means) over each opening.",
        json_schema_extra=unit(VOLUME))
    surface_area: float = Field(description="Sum of the enclosure faces' areas (units², net of holes, gross of "
                                "subsurfaces).", json_schema_extra=unit(AREA))
    net_surface_area: float = Field(description="surface_area minus the subsurfaces' areas (units², each times its "
                                    "multiplier): the opaque area.",
                                    json_schema_extra=unit(AREA))
    floor_area: float = Field(
        description="Floor area (units²): the area of the zone's faces whose outward normal points down within "
        f"{FLOOR_CONE_DEG:g}° of vertical (the horizontal faces the zone stands on, a sloped floor's projection "
        "not taken: each face's own area), net of their holes, gross of their subsurfaces; faces turned the wrong "
        "way are counted by their corrected orientation. 0 when no face faces down.", json_schema_extra=unit(AREA))
    closed: bool = Field(description="Every edge is used by an even number of the zone's faces (no open edge).")
    orientation: Literal["outward", "inward", "mixed"] = Field(
        description="outward: every face's normal points out of the zone; inward: every face points in; mixed: "
        "some faces disagree with their neighbours (misoriented_faces), or the surface cannot be oriented.")
    misoriented_faces: list[str] = Field(description="Faces whose normal points into the zone (or disagrees with their "
                                         "neighbours); the first 1000 when the result does not list every face.")
    misoriented_face_count: int | None = Field(default=None, description="How many faces are misoriented.")
    flux_volumes: list[float] = Field(
        description="Volumes (units³) from the flux of x, y and z alone through the surface: equal to each other "
        "only when the surface is closed.", json_schema_extra=unit(VOLUME))
    vector_area_sum: list[float] = Field(
        description="Sum of the faces' area vectors (units²): zero for a closed surface.", json_schema_extra=unit(AREA))
    open_edges: list[EdgeReport] = Field(description="Edges used by an odd number of the zone's faces (the first 1000).")
    open_edge_count: int
    non_manifold_edges: list[EdgeReport] = Field(description="Edges used by more than two of the zone's faces (the first 1000).")
    non_manifold_edge_count: int
    non_manifold_vertices: list[Point3] = Field(description="Vertices where separate sheets of the zone's surface "
                                                "touch (request units).", json_schema_extra=unit(LENGTH))
    t_junctions_repaired: int = Field(description="Vertices inserted into face loops because they lay on an edge.")
    components: int = Field(description="Connected pieces of the zone's surface (across manifold edges).")
    euler_characteristic: int = Field(description="V - E + F - (inner loops), over the zone's surface.")
    genus: int | None = Field(description="Handles (through holes) of the surface; null when non-manifold or not orientable.")
    faces: list[str] = Field(description="Ids of the faces bounding the zone (empty when the result does not list "
                             "every face: see faces_listed).")
    face_count: int | None = Field(default=None, description="How many faces bound the zone.")
    multiplier: int = Field(default=1, description="How many times the totals count this zone (zone_multipliers); "
                            "its measures here are one copy's.")
    part_of_total_floor_area: bool = Field(
        default=True, description="Whether total_floor_area counts this zone's floor (false: named in "
        "zones_outside_total_floor_area, EnergyPlus' Part of Total Floor Area = No).")


class FaceResult(BaseModel):
    id: str
    zones: list[str]
    parent: str | None = None
    area: float = Field(description="Area (units²) of the face net of its holes, gross of its subsurfaces.",
                        json_schema_extra=unit(AREA))
    net_area: float = Field(description="area minus the subsurfaces' areas (units²), each times its multiplier.",
                            json_schema_extra=unit(AREA))
    multiplier: int = Field(default=1, description="A subsurface's: how many identical copies its host holds "
                            "(subsurface_multipliers); its area here is one copy's.")
    perimeter: float = Field(description="Length of all the face's loops (units).", json_schema_extra=unit(LENGTH))
    normal: list[float] = Field(description="Unit normal (Newell), pointing out of the first zone as given.",
                                json_schema_extra=unit("1"))
    planarity_error: float = Field(description="Largest distance of a vertex from the face's plane (units).",
                                   json_schema_extra=unit(LENGTH))


class Adjacency(BaseModel):
    zones: list[str] = Field(description="The two zones [a, b].")
    faces: list[str] = Field(description="The faces they share (one face listed with both zones, or two coincident faces).")
    area: float = Field(description="Shared area (units²).", json_schema_extra=unit(AREA))


class PolyhedraResult(BaseModel):
    """Lengths in ``units``, areas in ``units``², volumes in ``units``³ (the request's unit; a file's own unit is
    converted to it, as report.details.source.units says)."""

    kind: Literal["polyhedra"] = Field(default="polyhedra", description="The solver kind of this result (what tells the "
                                   "results of GET /v1/jobs/{id}/result apart).")
    units: Units = Field(description="The length unit of every length, area (units²) and volume (units³) here.")
    zones: list[ZoneResult]
    faces: list[FaceResult] = Field(description="Every face, when faces_listed (else empty: the zones.csv artifact "
                                    "has a row per face when faces_in_csv).")
    faces_listed: bool = Field(default=True, description="Whether faces and each zone's faces list every face "
                               "(the option list_faces).")
    faces_in_csv: bool | None = Field(default=None, description="Whether the zones.csv artifact has a row per face "
                                      f"after the zone rows (the option faces_csv; omitted, up to {MAX_LISTED_FACES} "
                                      "faces). When neither this nor faces_listed, the per-face numbers are nowhere: "
                                      "send options.faces_csv true (or list_faces true) to have them. Null in a "
                                      "result stored before this field.")
    edge_length_total: float = Field(description="Total length (units) of the distinct edges of all faces.",
                                     json_schema_extra=unit(LENGTH))
    adjacency: list[Adjacency]
    total_volume: float | None = Field(description="Sum of the zones' volumes (units³), each times its multiplier; "
                                       "null when a zone is not closed. Of a file cut short (an IFC cut "
                                       "mid-entity), those of the zones read: the report's verdict "
                                       "totals_not_determined says they are not the building's.",
                                       json_schema_extra=unit(VOLUME))
    total_floor_area: float = Field(description="Sum of the floor areas (units²) of the zones that are "
                                    "part_of_total_floor_area, each times its multiplier (EnergyPlus' total floor "
                                    "area); of a file cut short, those of the zones read (totals_not_determined).",
                                    json_schema_extra=unit(AREA))
    report: Report
