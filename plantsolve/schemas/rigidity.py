"""Request and result models of the ``rigidity`` solver (jointed assemblies: mobility, rigid clusters,
collisions, docking).

Conventions
-----------
- ``bodies`` and ``joints`` are in the request's ``units``; LEGO ``parts`` are in LDraw units (LDU:
  1 stud pitch = 20, a brick 24 high, a plate 8, −y up) whatever ``units`` says. A request holds
  bodies and joints, or parts, not both. Results use the same length unit (``length_unit``).
- Rotations of bodies are quaternions ``[w, x, y, z]``; rotations of parts are 3×3 matrices given
  row-major as 9 numbers, as in an LDraw type-1 line (``a b c d e f g h i``).
- ``dof`` counts motions of the bodies relative to each other: the whole model's 6 rigid motions
  are excluded once, and every further unconnected piece adds 6.
"""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import BaseModel, BeforeValidator, Field

from plantsolve.schemas.common import (Direction3, FiniteFloat, Number, Point3, Quaternion, Report, StrictModel,
                                       Units, json_integer, plain_numbers, unit)

MAX_BODIES = 20_000
MAX_JOINTS = 100_000
MAX_MESH_VERTICES = 200_000

Name = Annotated[str, Field(min_length=1, max_length=200)]
PositiveLength = Annotated[Number, Field(allow_inf_nan=False, gt=0.0, le=1e12)]
VertexIndex = Annotated[int, Field(ge=0, lt=MAX_MESH_VERTICES), BeforeValidator(json_integer)]
JointType = Literal["rigid", "hinge", "ball", "slider", "cylindrical"]
# a result's joints may also be planar: a LEGO contact joint (face on face), inferred, never a request's
ResultJointType = Literal["rigid", "hinge", "ball", "slider", "cylindrical", "planar"]
Matrix9 = Annotated[list[Annotated[Number, Field(allow_inf_nan=False, ge=-1e6, le=1e6)]],
                    Field(min_length=9, max_length=9)]


class BoxShape(StrictModel):
    center: Point3 = Field(description="Centre [x, y, z] (units).")
    size: Annotated[list[PositiveLength], Field(min_length=3, max_length=3)] = Field(
        description="Edge lengths along the box's own x, y, z (units).")
    rotation: Quaternion = Field(default=[1.0, 0.0, 0.0, 0.0], description="Orientation [w, x, y, z].")


class MeshShape(StrictModel):
    vertices: list[Point3] = Field(min_length=4, max_length=MAX_MESH_VERTICES, description="[x, y, z] (units).")
    faces: list[Annotated[list[VertexIndex], Field(min_length=3, max_length=3)]] = Field(
        min_length=4, max_length=2 * MAX_MESH_VERTICES, description="Triangles as vertex indices.")


class Shape(StrictModel):
    box: BoxShape | None = None
    mesh: MeshShape | None = None


class Body(StrictModel):
    id: Name
    shape: Shape | None = Field(default=None, description="A box or a mesh for collision checks; null: no shape.")


class JointIn(StrictModel):
    id: Name
    type: JointType = Field(description="rigid, hinge (revolute), ball (spherical), slider (prismatic), cylindrical.")
    bodies: Annotated[list[Name], Field(min_length=2, max_length=2)] = Field(description="The two body ids [A, B].")
    point: Point3 = Field(description="A point of the joint [x, y, z] (units): on the hinge line, the ball's centre.")
    axis: Direction3 | None = Field(
        default=None, description="Axis [dx, dy, dz] of a hinge, slider or cylindrical joint (any length but 0).")


class PartIn(StrictModel):
    id: Name
    part: Annotated[str, Field(min_length=1, max_length=64)] = Field(
        description="LDraw part number, e.g. '3001' (a 2 x 4 brick); '.dat' is optional.")
    position: Point3 = Field(description="Origin of the part [x, y, z] in LDraw units.")
    rotation: Matrix9 = Field(default=[1, 0, 0, 0, 1, 0, 0, 0, 1],
                              description="3 x 3 rotation, row-major (LDraw's a b c d e f g h i).")


class DockOptions(StrictModel):
    part: Annotated[str, Field(min_length=1, max_length=64)] = Field(description="Catalogue part number to dock.")
    limit: Annotated[int, Field(ge=1, le=500), BeforeValidator(json_integer)] = Field(
        default=10, description="How many candidate poses to return (most connections first).")


class RigidityOptions(StrictModel):
    _plain_numbers = plain_numbers("contact_tolerance", "rank_tolerance")

    dock: DockOptions | None = Field(default=None, description="A part to find docking poses for (parts models).")
    contact_tolerance: FiniteFloat = Field(
        default=0.01, ge=0.0, le=100.0,
        description="Penetration depth (model length unit; LDU for parts) up to which touching shapes are contact, "
        "not collision: at most 100 (4 cm of LEGO, 10 cm in mm; a deeper overlap is no contact in any unit).")
    rank_tolerance: FiniteFloat = Field(
        default=1e-9, ge=1e-15, le=1e-3,
        description="Float rank cut-off (non-integer geometry only): singular values below rank_tolerance · "
        "max(rows, columns) · σ_max are zero, on coordinates centred and divided by the model's size.")


class RigidityRequest(StrictModel):
    units: Units = Field(default="mm", description="Length unit of bodies and joints (parts are in LDraw units).")
    bodies: list[Body] = Field(default_factory=list, max_length=MAX_BODIES)
    joints: list[JointIn] = Field(default_factory=list, max_length=MAX_JOINTS)
    parts: list[PartIn] = Field(default_factory=list, max_length=MAX_BODIES,
                                description="LEGO parts (LDraw units); their connections are inferred.")
    options: RigidityOptions = Field(default_factory=RigidityOptions)
    source: dict[str, Any] | None = Field(
        default=None, description="What the upload parser read (lines skipped with reasons); set by the parser.")


LENGTH_UNIT = "{length_unit}"  # the result's own length_unit field ('ldu' for parts: 1 LDU = 0.4 mm)


class JointResult(BaseModel):
    id: str
    type: ResultJointType = Field(description="rigid, hinge (revolute), ball (spherical), slider (prismatic), "
                                  "cylindrical, or planar (a contact joint: the slide in the faces' plane and the "
                                  "turn about their normal, its axis).")
    bodies: list[str]
    point: list[float] = Field(description="A point of the joint [x, y, z] (length_unit).",
                               json_schema_extra=unit(LENGTH_UNIT))
    axis: list[float] | None = Field(description="Unit axis [dx, dy, dz] of a hinge, slider or cylindrical joint, the "
                                     "normal of a planar one; "
                                     "null for a ball joint.", json_schema_extra=unit("1"))
    origin: str = Field(description="input (a request joint) or the inferred LEGO connection: stud, pin, axle, "
                        "hinge, ball (ball in socket), clip (clip on bar), bar (bar in a bar or axle hole), "
                        "group (a grouped fit, e.g. tyre on rim), fit (a snap cylinder in its bore: an arm in a "
                        "torso), contact (planar: collision boxes touching face on face as drawn where no snap "
                        "meets and neither face has studs across the contact; holds 3 degrees of freedom, the "
                        "normal's translation and the two tilts).")
    connections: int = Field(description="Connection points behind the joint (several studs make one rigid joint).")
    moves: bool = Field(description="The joint's relative twist is non-zero in some motion of the model.")


class Collision(BaseModel):
    bodies: list[str] = Field(description="The two ids.")
    depth: float = Field(description="Penetration depth (length_unit).", json_schema_extra=unit(LENGTH_UNIT))


class DockingCandidate(BaseModel):
    part: str
    position: list[float] = Field(description="Origin of the docked part [x, y, z] (LDU).",
                                  json_schema_extra=unit(LENGTH_UNIT))
    rotation: list[float] = Field(description="3 x 3 rotation, row-major.", json_schema_extra=unit("1"))
    connections: int = Field(description="Connection points the pose joins.")
    connects_to: list[str] = Field(description="Parts it connects to.")


class UnknownPart(BaseModel):
    id: str
    part: str


class PartJoints(BaseModel):
    id: str
    part: str = Field(description="The part number.")
    joints: list[str] = Field(description="Ids of the joints the part is in (empty: joined to nothing).")
    joined_to: list[str] = Field(description="Ids of the parts those joints join it to.")


class Piece(BaseModel):
    parts: list[str] = Field(description="Ids of the parts of one connected piece.")
    sub_build: str | None = Field(description="What the piece is when it is a sub-build that may stand apart: the "
                                  "names of the placed LDraw sub-models whose every known part it is (and only "
                                  "those, none touching a part of the largest piece: whole sub-models lying against "
                                  "the build are a part of it whose joint was not found), joined by ' + ', or "
                                  "'minifigure' (only minifigure parts); null for a piece of the build itself.")
    drawn_apart: bool = Field(default=False, description="True for a piece (no held sub-build, not the largest) that "
                              "the drawing itself places apart, a separate build: its parts stand clear of every part "
                              "outside it by more than a slip (collision boxes at least 3.1 LDU apart, parts without "
                              "one at their origin), no connection point of it lies within 10 LDU (half a stud "
                              "pitch) of a mate, and no part outside the catalogue lies beside it (origins within 60 "
                              "LDU). A second vehicle, an animal, an accessory or spare parts laid aside, or a part "
                              "fallen off: no joint can join it as drawn. Listed in report.details.separate_builds "
                              "and the separate_builds warning; other pieces apart are named in separate_pieces (a "
                              "joint not found).")


class LoneMotion(BaseModel):
    parts: list[str] = Field(description="Ids of the rigid cluster's parts (or bodies).")
    numbers: list[str] = Field(description="Their part numbers, in the same order (bodies: empty).")
    point: list[float] = Field(description="A point [x, y, z] of the line it turns about (length_unit).",
                               json_schema_extra=unit(LENGTH_UNIT))
    axis: list[float] = Field(description="The line's unit direction [dx, dy, dz].", json_schema_extra=unit("1"))
    slides: bool = Field(description="Every joint with the rest is cylindrical: it slides along the line too.")
    dof: int = Field(description="Its share of dof: 1 (turns), 2 (turns and slides).")


class RigidityResult(BaseModel):
    kind: Literal["rigidity"] = Field(default="rigidity", description="The solver kind of this result (what tells the "
                                   "results of GET /v1/jobs/{id}/result apart).")
    length_unit: str = Field(description="Unit of every length in the result: the request's units, or 'ldu' for parts "
                             "(LDraw units: 1 LDU = 0.4 mm, a stud pitch 20).")
    dof: int = Field(description="Degrees of freedom relative to each other (6 rigid motions of the whole excluded; "
                     "each further unconnected piece adds 6).")
    generic_dof: int = Field(description="The (6,6) pebble game's count for generic positions (exact for hinges and "
                             "rigid joints; for ball, slider and cylindrical joints a lower bound).")
    special_position: bool = Field(description="dof > generic_dof: the geometry moves more than its joint count says.")
    rigid: bool | None = Field(description="One connected piece with dof 0. Of a LEGO model: of its known parts, "
                               "and null when the parts not in the catalogue are at least half of it (a chain of "
                               "segments, an LSynth hose, counted as one): the verdict rigidity_not_determined (NOT "
                               "DETERMINED). A LEGO model is one build unless its drawing says otherwise: known parts "
                               "in pieces besides held sub-builds (Piece.sub_build) and separate builds drawn apart "
                               "(Piece.drawn_apart) make it null with the verdict one_piece_not_determined (NOT "
                               "DETERMINED: loose as drawn, or held by a joint the catalogue does not know, which the "
                               "drawing cannot tell); a model of bodies and "
                               "joints in several pieces is false with no verdict (its joints are the user's).")
    clusters: list[list[str]] = Field(description="Maximal rigid clusters; every body or part in exactly one.")
    lone_motions: list[LoneMotion] = Field(default_factory=list, description="The rigid clusters that turn alone "
                                           "about one line through every joint they have with the rest, moving no "
                                           "other part: a pin or an axle turning in round holes, a wheel or a gear "
                                           "on its axle, a door on its hinge. Each piece's largest cluster is its "
                                           "reference and is not listed. Their dof add up: this list is what "
                                           "accounts for dof beyond linked_dof.")
    linked_dof: int | None = Field(default=None, description="dof less the lone motions' dof and less 6 for each "
                                   "connected piece beyond the first: the motions that move several clusters "
                                   "relative to each other (a hinge chain, a linkage). 0: the model moves only by "
                                   "parts turning (or sliding) alone in place.")
    superbricks: list[list[str]] = Field(description="Groups joined by rigid connections alone.")
    joints: list[JointResult]
    redundant_constraints: int = Field(description="Constraint rows minus the rank of the constraint matrix.")
    collisions: list[Collision]
    docking: list[DockingCandidate]
    unknown_parts: list[UnknownPart] = Field(description="Parts not in the catalogue: not analysed.")
    parts: list[PartJoints] = Field(default_factory=list, description="Each known LEGO part with its joints, in the "
                                    "request's order.")
    pieces: list[Piece] = Field(default_factory=list, description="The connected pieces of the known parts, largest "
                                "first (bodies and joints models: empty).")
    rank_method: Literal["modular", "svd"] = Field(description="modular: exact integer rank; svd: float rank.")
    report: Report
