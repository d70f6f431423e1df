"""Request and result models of the ``alignment`` solver.

A pipe system is a set of components (straight pipes and catalogue fittings), each with
ports (the paper's *ConnectionPoints*: a point and a unit direction pointing out of the
component), and a list of connections between ports. The solver moves the components as
little as possible so that every connected pair of ports ends at the same point with
opposite directions.

Conventions: lengths in the request's ``units``; angles in degrees; quaternions
``[w, x, y, z]``; dual quaternions ``[w, x, y, z, w', x', y', z']`` (real part then dual
part, ``x -> R x + t`` with dual part ``0.5 * (0, t) * real``).
"""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict, Field

from plantsolve.schemas.common import (
    LENGTH,
    Direction3,
    FiniteFloat,
    Flag,
    Integer,
    Point3,
    Quaternion,
    Report,
    StrictModel,
    Units,
    Vec3,
    plain_numbers,
    unit,
)

FittingType = Literal[
    "elbow", "bend", "tee", "cross", "reducer", "valve", "flange", "cap", "olet", "tie_in", "other"
]


class Port(StrictModel):
    """A ConnectionPoint: where a component joins its neighbour."""

    position: Point3 = Field(description="Port centre point, in the request's units (|x| <= 1e12).",
                             json_schema_extra=unit(LENGTH))
    direction: Direction3 = Field(
        description="Direction pointing out of the component (any non-zero length, components within 1e9; "
        "normalised by the solver; a result's are unit vectors).",
        json_schema_extra=unit("1"),
    )


class Component(StrictModel):
    """A straight pipe (two collinear, opposite ports; its length may change) or a rigid fitting."""

    _plain_numbers = plain_numbers("radius")

    # stated for clients and generated tests; the solver's input check says why a pipe is refused
    model_config = ConfigDict(json_schema_extra={
        "if": {"properties": {"kind": {"const": "pipe"}}},
        "then": {"properties": {"ports": {"minItems": 2, "maxItems": 2}}},
    })

    id: str = Field(min_length=1, max_length=200, description="Unique component id.")
    kind: Literal["pipe", "fitting"] = Field(description="'pipe' (stretchable) or 'fitting' (rigid).")
    type: FittingType | None = Field(
        default=None,
        description="Catalogue type of a fitting (elbow, tee, cross, reducer, valve, flange, cap, olet, "
        "tie_in, other); decides the minimum number of ports. Ignored for pipes.",
    )
    radius: FiniteFloat | None = Field(
        default=None,
        gt=0,
        le=1e12,
        description="Outside radius in the request's units. For pipes it sets the minimum pipe length "
        "(options.min_pipe_length_factor x radius); without it a hundredth of the measured length is used.",
    )
    fixed: Flag = Field(
        default=False,
        description="A tie-in: the component never moves (its output coordinates are its input, bit for bit).",
    )
    up: Direction3 | None = Field(
        default=None,
        json_schema_extra=unit("1"),
        description="Up vector of a fitting whose ports are collinear (e.g. a valve stem). After alignment it is "
        "re-established as the original up projected onto the plane normal to the new port axis.",
    )
    ports: list[Port] = Field(min_length=1, max_length=16, description="Ports in a stable order.")


class Connection(StrictModel):
    """Two ports that must end at the same point with opposite directions."""

    model_config = ConfigDict(extra="forbid", populate_by_name=True, serialize_by_alias=True)

    from_: tuple[str, Integer] = Field(alias="from", description="[component id, port index] of one side.")
    to: tuple[str, Integer] = Field(description="[component id, port index] of the other side.")


class AlignmentOptions(StrictModel):
    """Tolerances and method. Unset tolerances come from ``tolerance_profile``."""

    _plain_numbers = plain_numbers("position_tolerance", "angle_tolerance", "pipe_stiffness", "min_pipe_length_factor",
                                   "step_limit", "explosion_factor", "shape_tolerance", "connection_tolerance")

    tolerance_profile: Literal["auto", "autocad_plant3d", "aveva_e3d", "revit", "custom"] = Field(
        default="auto",
        description="Preset tolerances. 'auto' (default): for a PCF, the exporting tool named in the file sets the "
        "profile and the coordinates' printed precision the rounding floor (differences a rounding of the printed "
        "digits can cause are not moved); for JSON, 1e-10 units and 1e-10 rad. autocad_plant3d (1e-10 drawing "
        "units, 1e-10 rad), aveva_e3d (1 mm, 0.01 rad), revit (1e-9 ft, 1e-10 rad), custom (1e-10 units, 1e-10 rad). "
        "Explicit position_tolerance / angle_tolerance override the profile. The report names what was used.",
    )
    position_tolerance: FiniteFloat | None = Field(
        default=None, gt=0, le=1000.0,
        description="Largest accepted port gap, in the request's units (at most 1000: a metre in mm; a gap wider "
        "than a pipe run is no scan tolerance)."
    )
    angle_tolerance: FiniteFloat | None = Field(
        default=None,
        gt=0,
        le=10.0,
        description="Largest accepted angle between a port direction and the reversed direction of its "
        "partner, in degrees (1e-10 rad = 5.73e-9 deg; at most 10: beyond it two ports do not face each other).",
    )
    max_iterations: Integer = Field(
        default=4000, ge=1, le=1_000_000,
        description="Iteration cap of either method (direct: Gauss-Newton and refinement steps over all cut rounds; "
        "dual_quaternion: alternating steps). A run stopped by the cap says so in its stop reason.",
    )
    anchor: Flag = Field(
        default=True,
        description="When a connected network has no fixed component, hold one still (a tie_in, else an end flange, "
        "else its largest component) so the result is reproducible; the report names it.",
    )
    method: Literal["direct", "dual_quaternion"] = Field(
        default="direct",
        description="'direct': rotation averaging + sparse constrained least squares (closes loops exactly); "
        "'dual_quaternion': the paper's alternating mean-displacement iteration.",
    )
    pipe_stiffness: FiniteFloat = Field(
        default=10.0,
        ge=1e-6,
        le=1e6,
        description="How much more a pipe axis resists moving than a fitting of the same length (1e-6 to 1e6: "
        "beyond, one of the two weights vanishes in the other's round-off).",
    )
    min_pipe_length_factor: FiniteFloat = Field(
        default=0.1, gt=0, le=100.0,
        description="Minimum pipe length as a multiple of the pipe radius (no flips; at most 100 radii)."
    )
    step_limit: FiniteFloat | None = Field(
        default=None,
        gt=0,
        le=1e6,
        description="Dual-quaternion method: largest port movement of a fitting per step, in units (at most 1e6) "
        "(pipes get half, long pipes less). Default: half the largest initial gap.",
    )
    explosion_factor: FiniteFloat = Field(
        default=50.0,
        gt=1,
        le=1e9,
        description="Dual-quaternion method (more than 1, at most 1e9): if the largest gap exceeds this multiple of the initial largest gap, "
        "the connection with the highest error is cut and the run restarts.",
    )
    max_cuts: Integer = Field(default=50, ge=0, le=1_000_000,
                              description="Most connections the solver may cut (at most the 1,000,000 connections "
                              "a request may hold).")
    fixed_components: list[str] = Field(
        default_factory=list, description="Ids of additional tie-ins (same as fixed=true on the component)."
    )
    shape_tolerance: FiniteFloat = Field(
        default=1.0,
        gt=0,
        le=45.0,
        description="Degrees: how far a pipe's ports may be from collinear-and-opposite before the input is rejected "
        "(at most 45: beyond, a bend is no straight pipe).",
    )
    connection_tolerance: FiniteFloat | None = Field(
        default=None,
        gt=0,
        le=1000.0,
        description="PCF upload only: end points closer than this (units, at most 1000) are connected. "
        "Default: half the smaller bore radius.",
    )


class AlignmentRequest(StrictModel):
    """Root of ``POST /v1/alignment/jobs``."""

    units: Units = "mm"
    components: list[Component] = Field(min_length=1, max_length=500_000)
    connections: list[Connection] = Field(default_factory=list, max_length=1_000_000)
    options: AlignmentOptions = Field(default_factory=AlignmentOptions)
    source_pcf: str | None = Field(
        default=None,
        description="Original PCF text when the request came from a .pcf upload; used to write aligned.pcf "
        "with every untouched attribute preserved. Component ids map to its component blocks.",
    )
    source_encoding: Literal["utf-8", "utf-8-sig", "utf-16", "cp1252", "latin-1"] | None = Field(
        default=None,
        description="Text encoding of the uploaded PCF (Windows plant-design tools write cp1252); aligned.pcf "
        "is written back in the same encoding.",
    )


class Transform(BaseModel):
    """Rigid motion ``x -> R x + t`` taking the input pose to the output pose."""

    dual_quaternion: list[float] = Field(
        description="[w, x, y, z, w', x', y', z'] (unit dual quaternion): the real part [w, x, y, z] is a pure number, "
        "the dual part [w', x', y', z'] = 0.5 (0, t) * real is in the result's units (x-unit-dual).",
        json_schema_extra={**unit("1"), "x-unit-dual": LENGTH})
    rotation: Quaternion = Field(description="Rotation quaternion [w, x, y, z].", json_schema_extra=unit("1"))
    translation: Vec3 = Field(description="Translation in units (applied after the rotation).",
                              json_schema_extra=unit(LENGTH))


class ComponentResult(BaseModel):
    id: str
    ports: list[Port] = Field(description="Aligned ports, same order as the request.")
    transform: Transform = Field(
        description="Rigid part of the motion (for pipes: the axis motion; port 0 maps exactly, port 1 also moves "
        "by length_change along the axis)."
    )
    displacement: float = Field(description="Largest movement of any of its ports, in units.",
                                json_schema_extra=unit(LENGTH))
    rotation_angle: float = Field(description="Rotation angle of the transform, degrees.", json_schema_extra=unit("deg"))
    length_change: float | None = Field(default=None, description="Pipes: new length minus old length, units.",
                                        json_schema_extra=unit(LENGTH))
    up: list[float] | None = Field(default=None, description="Re-established up vector (fittings with an up).",
                                   json_schema_extra=unit("1"))


class ConnectionResult(BaseModel):
    model_config = ConfigDict(populate_by_name=True, serialize_by_alias=True)

    from_: tuple[str, int] = Field(alias="from")
    to: tuple[str, int]
    position_error: float = Field(description="Distance between the two ports after alignment, units.",
                                  json_schema_extra=unit(LENGTH))
    angle_error: float = Field(description="Angle between one direction and the reversed other, degrees.",
                               json_schema_extra=unit("deg"))
    cut: bool = Field(description="True if the solver cut this connection to resolve a conflict or explosion.")


class AlignmentResult(BaseModel):
    kind: Literal["alignment"] = Field(default="alignment", description="The solver kind of this result (what tells the "
                                   "results of GET /v1/jobs/{id}/result apart).")
    units: Units = Field(default="mm", description="Length unit of every length and position in this result (the "
                         "request's units); angles are in degrees.")
    angle_unit: Literal["deg"] = Field(default="deg", description="Unit of every angle in this result.")
    converged: bool
    iterations: int = Field(description="Iterations of the chosen method (direct: Gauss-Newton + refinement steps).")
    max_position_error: float = Field(description="Largest gap over connections that were not cut, units.",
                                      json_schema_extra=unit(LENGTH))
    max_angle_error: float = Field(description="Largest angle error over connections that were not cut, degrees.",
                                   json_schema_extra=unit("deg"))
    components: list[ComponentResult]
    connections: list[ConnectionResult]
    cut_connections: list[int] = Field(description="Indices (request order) of the connections that were cut.")
    report: Report
