"""Request and result models of the ``tube`` solver: bent-tube reconstruction from scans.

LRA convention (the public contract of ``lra`` tables, measured and nominal):

* The local frame of the tube start: **x** = initial tangent (direction of travel along the
  first straight), **y** = in-plane normal toward the centre of the first bend, **z** = x × y.
  ``orientation`` is the unit quaternion ``[w, x, y, z]`` that maps this local frame to the
  world frame; ``start`` is the world position of the tube's first end.
* Each row is applied in turn: go straight ``length``; rotate the in-plane normal about the
  current tangent by ``rotation`` (right-hand rule, degrees); bend by ``angle`` (degrees) with
  ``bend_radius`` toward the normal (the centre of the bend lies at ``bend_radius`` along the
  normal).
* A tube with n bends has n + 1 rows; the first row's rotation is 0 (the frame fixes the first
  bend plane) and the last row's angle is 0 (it is only the final straight). Two bends that
  follow each other directly are joined by a row with length 0.
* LRA → XYZ → LRA round trips exactly (for bends under 180°, where the control polygon
  exists); LRA → segments → LRA round trips for every bend angle.
"""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import BaseModel, BeforeValidator, Discriminator, Field, StrictInt, Tag, model_validator

from plantsolve.schemas.common import (LENGTH, Coordinate, Diagnostic, FileUnits, FiniteFloat, Flag, Number, Point3,
                                      Quaternion, Report, StrictModel, Units, Vec3, json_integer, plain_numbers, unit)

MAX_POINTS = 5_000_000
# the largest length an option may hold, in the request's units: 1e6 is a kilometre in millimetres and 300 km in
# feet, far beyond any tube; beyond it a number is a typing accident (1e300), refused at intake naming the field.
# How a radius compares with the scan itself is checked against the samples (``validation``).
MAX_OPTION_LENGTH = 1e6
MAX_NOMINAL_LENGTH = 1e12  # a nominal's lengths: the coordinates' bound (``common.MAX_COORDINATE``)
DEG = unit("deg")
LEN = unit(LENGTH)

FILE_UNITS_HELP = (
    "Length unit of the coordinates in an uploaded point file (uploads only): a request unit or micrometres ('um', "
    "also 'µm'). It overrides the file format's own "
    "convention, which is: LAS/LAZ — the linear unit of the file's CRS (OGC WKT VLR/EVLR, else GeoTIFF keys "
    "ProjLinearUnits 3076 / VerticalUnits 4099), metres when the file states none (as scanners write them; the "
    "report then warns 'file_units_assumed'); E57 — metres (the standard's); XYZ, CSV, TXT — the unit their column "
    "header states for x, y, z (`x [m]`, `x_mm`), if any; PLY, STL, OBJ, NPY and headers without one — no unit: read in the request's `units` unless this says otherwise. Points are converted into the request's "
    "`units`, and the report states the conversion (`report.details.source.units`: file unit, request unit, "
    "factor, and where the file unit came from). Not accepted with a .json upload (a JSON request states its "
    "own `units`); ignored, with a warning, in a JSON request body."
)


class NpyPoints(StrictModel):
    """Points as a base64-encoded NPY array of shape (N, 3) (float32 or float64)."""

    npy_base64: str = Field(
        min_length=1,
        description="base64 of the bytes of a .npy file holding an (N, 3) float array, "
        "one row [x, y, z] per sample, in the request's units. Every value must be finite; "
        f"at most {MAX_POINTS} rows. Decoded and checked by the solver (422 on points).",
    )


class LraRow(StrictModel):
    """One LRA row: straight, then rotate the bend plane, then bend (see module convention)."""

    _plain_numbers = plain_numbers("length", "rotation", "angle", "bend_radius", "sigma_length", "sigma_rotation",
                                   "sigma_angle", "sigma_bend_radius")

    length: FiniteFloat = Field(ge=0, le=MAX_NOMINAL_LENGTH, json_schema_extra=LEN,
                                description="Straight length before the bend, in the request's units.")
    rotation: FiniteFloat = Field(
        default=0.0, ge=-360, le=360, json_schema_extra=DEG,
        description="Rotation of the in-plane normal about the current tangent before the bend, "
        "degrees, right-hand rule. 0 in the first row.",
    )
    angle: FiniteFloat = Field(
        default=0.0, ge=0, lt=360, json_schema_extra=DEG, description="Bend angle in degrees (0 in the last row)."
    )
    bend_radius: FiniteFloat = Field(
        default=0.0, ge=0, le=MAX_NOMINAL_LENGTH, json_schema_extra=LEN,
        description="Centreline bend radius (CLR) of this bend; 0 in the last row."
    )
    sigma_length: FiniteFloat | None = Field(
        default=None, ge=0, json_schema_extra=LEN, description="Results: standard deviation of the length. For an end "
        "straight, whose extent is where the samples end, the spacing of the samples along the tube there: the tube "
        "ends about one to three times this beyond the last sample when they reach its cut end (its length is a "
        "lower bound, `length_bound`)."
    )
    sigma_rotation: FiniteFloat | None = Field(default=None, ge=0, json_schema_extra=DEG,
                                               description="Results: standard deviation, degrees.")
    sigma_angle: FiniteFloat | None = Field(default=None, ge=0, json_schema_extra=DEG,
                                            description="Results: standard deviation, degrees.")
    sigma_bend_radius: FiniteFloat | None = Field(
        default=None, ge=0, json_schema_extra=LEN,
        description="Results: standard deviation of the bend radius (0 when held by the options)."
    )
    determined: Flag | None = Field(
        default=None, description="Results: false when a field of this row is not determined by the samples "
        "(listed in `undetermined`): an end straight the samples stop short on, or a bend they see from one side "
        "only. Null in a nominal.")
    undetermined: list[Literal["length", "rotation", "angle", "bend_radius"]] = Field(
        default_factory=list, description="Results: the fields of this row the samples do not determine; each has a "
        "bound (`length_bound`, `angle_bound`) or a sigma too large for its value.")
    length_bound: Literal["lower"] | None = Field(
        default=None, description="Results: 'lower' on the two end straights: their length is where the samples end, "
        "so the tube is at least this long (by up to about `sigma_length` more when the samples reach its end).")
    angle_bound: Literal["lower"] | None = Field(
        default=None, description="Results: 'lower' on a bend seen from one side only (the samples stop inside it or "
        "just after it): it turns at least this far.")


class XyzClrPoint(StrictModel):
    """One point of an XYZ-CLR nominal: the intersection of two consecutive straights of the centreline (or an
    end of the tube) and the centreline bend radius of the bend there."""

    _plain_numbers = plain_numbers("x", "y", "z", "clr")

    x: Coordinate
    y: Coordinate
    z: Coordinate
    clr: FiniteFloat | None = Field(default=None, ge=0, le=MAX_NOMINAL_LENGTH, description="Centreline bend radius of the bend at this "
                                    "point, request units; null (or 0) at the two ends.")


NOMINAL_CSV_MAX = 1_000_000

INSPECTION_DEFAULTS_MM = {"length": 1.0, "bend_radius": 1.0, "end_point": 2.0}
INSPECTION_DEFAULTS_DEG = {"rotation": 1.0, "angle": 0.5}


class InspectionTolerances(StrictModel):
    """Symmetric tolerances (±) of an inspection per field. Null takes the default: length ±1 mm, rotation ±1°,
    angle ±0.5°, bend radius (CLR) ±1 mm, end point ±2 mm (the millimetre defaults are converted into the
    request's units)."""

    _plain_numbers = plain_numbers("length", "rotation", "angle", "bend_radius", "end_point")

    length: FiniteFloat | None = Field(default=None, gt=0, le=MAX_OPTION_LENGTH, json_schema_extra=LEN,
                                       description="Straight length, request units.")
    rotation: FiniteFloat | None = Field(default=None, gt=0, le=180, json_schema_extra=DEG,
                                         description="Rotation of the bend plane, degrees.")
    angle: FiniteFloat | None = Field(default=None, gt=0, le=180, json_schema_extra=DEG,
                                      description="Bend angle, degrees.")
    bend_radius: FiniteFloat | None = Field(default=None, gt=0, le=MAX_OPTION_LENGTH, json_schema_extra=LEN,
                                            description="Centreline bend radius, request units.")
    end_point: FiniteFloat | None = Field(default=None, gt=0, le=MAX_OPTION_LENGTH, json_schema_extra=LEN,
                                          description="Distance of each measured tube end from "
                                          "the nominal one after best-fit alignment, request units.")


class TubeOptions(StrictModel):

    _plain_numbers = plain_numbers("tolerance", "pipe_radius", "bend_radius", "dies", "damping")
    tolerance: FiniteFloat | None = Field(
        default=None,
        gt=0,
        le=MAX_OPTION_LENGTH,
        description="ε: maximum distance of the reconstructed spine polygon from the arc-line "
        "spline when choosing the number of segments (request units). Default: derived from the "
        "pipe radius and the estimated noise (max(0.08·pipe radius, 4·spine noise)).",
    )
    pipe_radius: FiniteFloat | None = Field(
        default=None, gt=0, le=MAX_OPTION_LENGTH,
        description="Known outer pipe radius (request units); fixed in every fit when given. It must fit the scan: "
        "no larger than the samples' extent, no smaller than half their spacing (else 422 naming it)."
    )
    bend_radius: FiniteFloat | None = Field(
        default=None,
        gt=0,
        le=MAX_OPTION_LENGTH,
        description="Known centreline bend radius (request units); when given all bends are "
        "fitted with this fixed radius.",
    )
    common_bend_radius: Flag = Field(
        default=False, description="Fit one bend radius shared by all bends (typical of rotary-draw benders); "
        "the same as bend_radius_model 'common'."
    )
    bend_radius_model: Literal["auto", "common", "dies", "per_bend"] = Field(
        default="auto",
        description="How the bend radii are fitted: 'common' (one die: one radius for all bends), 'dies' (two "
        "dies: two radii, bends assigned by the data), 'per_bend' (a free radius per bend), or 'auto' (the one "
        "with the smallest Bayesian information criterion on the surface residuals; reported in the result). It, "
        "`bend_radius`, `common_bend_radius` and `dies` must state one rule (422 naming them otherwise): a fixed "
        "`bend_radius` or `common_bend_radius` goes with 'common' or 'auto', `dies` with 'dies' or 'auto' (a single "
        "die also with 'common' and with a `bend_radius` equal to it).",
    )
    dies: list[Annotated[Number, Field(gt=0, le=MAX_OPTION_LENGTH, allow_inf_nan=False)]] | None = Field(
        default=None, min_length=1, max_length=20,
        description="Centreline radii of the dies available (request units): each bend gets the nearest die "
        "(by its freely fitted radius), and its radius is held at that die's.",
    )
    nominal: list[LraRow] | None = Field(
        default=None,
        min_length=1,
        max_length=10_000,
        description="Nominal LRA table (same convention and units) for inspection: the "
        "reconstruction is aligned to it and per-bend deviations and corrected LRA are reported.",
    )
    damping: FiniteFloat = Field(
        default=1.0,
        gt=0,
        le=1.5,
        description="Springback-correction damping factor: corrected = nominal + damping · "
        "(nominal − measured), for angle, rotation and length.",
    )
    nominal_xyz_clr: list[XyzClrPoint] | None = Field(
        default=None, min_length=2, max_length=10_000,
        description="Nominal as XYZ-CLR (start, intersection points of consecutive straights, end; CLR per bend), "
        "request units; converted to LRA (L = straight between tangent points, R = rotation between consecutive "
        "bend planes, A = angle between straights). Bends below 180° only. Instead of `nominal`.",
    )
    nominal_csv: str | None = Field(
        default=None, min_length=1, max_length=NOMINAL_CSV_MAX,
        description="Nominal as the text of a CSV file: LRA rows (length, rotation, angle, CLR; e.g. this "
        "service's lra.csv) or XYZ-CLR points (x, y, z, clr; e.g. its xyz_clr.csv). Comma, semicolon, tab or "
        "blank separated; a header names the columns (unit suffixes such as _mm or [in] are converted into the "
        "request's units), without one 4 numeric columns are LRA unless the first row has no CLR (then XYZ-CLR), "
        "and 5 start with a row number. Lines that cannot be read are skipped with a warning. Instead of `nominal`.",
    )
    nominal_format: Literal["auto", "lra", "xyz_clr"] = Field(
        default="auto", description="Format of `nominal_csv`: 'auto' (by its header, else by its first row).")
    inspection_tolerances: InspectionTolerances = Field(
        default_factory=InspectionTolerances, description="Tolerances of the inspection's pass/fail per field.")
    springback_model: Literal["per_bend", "linear_per_die"] = Field(
        default="per_bend",
        description="Angle correction: 'per_bend' (next command = nominal + springback of that bend, springback = "
        "commanded − measured with the nominal as commanded) or 'linear_per_die' (bends sharing a nominal CLR fit "
        "angle_out = k·angle_cmd + b; next command = (nominal − b)/k; a die with fewer than two distinct "
        "commanded angles falls back to k = 1).",
    )
    seed: Annotated[int, Field(ge=0, le=2**32 - 1), BeforeValidator(json_integer)] = Field(default=0, description="Seed of the subsampling random generator.")
    file_units: FileUnits | None = Field(default=None, description=FILE_UNITS_HELP)

    @model_validator(mode="after")
    def _one_nominal(self):
        given = [name for name in ("nominal", "nominal_xyz_clr", "nominal_csv") if getattr(self, name) is not None]
        if len(given) > 1:
            raise ValueError(f"give the nominal once: {', '.join(given)} are all set")
        return self

    @model_validator(mode="after")
    def _one_radius_rule(self):
        """The bend radius options say one thing: ``bend_radius`` held every bend at it whatever ``dies`` or
        ``bend_radius_model`` said, ``common_bend_radius`` overrode ``bend_radius_model``, ``dies`` overrode both,
        each without a word (a bend made on a 30 mm die among ``dies: [18, 30]`` was fitted at ``bend_radius: 18``).
        ``dies`` naming one radius is both one radius for every bend and each bend the nearest die."""
        one, die, free = "one radius for every bend", "each bend the nearest die", "a free radius per bend"
        radii = sorted(set(self.dies or []))
        said: list[tuple[str, set[str]]] = []
        if self.bend_radius is not None:
            said.append((f"bend_radius {self.bend_radius:g}", {one}))
        if self.common_bend_radius:
            said.append(("common_bend_radius", {one}))
        if radii:
            said.append((f"dies [{', '.join(f'{r:g}' for r in radii)}]", {one, die} if len(radii) == 1 else {die}))
        model = {"common": one, "dies": die, "per_bend": free}.get(self.bend_radius_model)
        if model is not None:
            said.append((f"bend_radius_model {self.bend_radius_model!r}", {model}))
        agreed = set.intersection(*(rules for _, rules in said)) if said else set()
        if said and not agreed:
            raise ValueError("the bend radius options contradict each other: " + "; ".join(
                f"{option} gives {' or '.join(sorted(rules))}" for option, rules in said)
                + ". Leave out all but one of these rules")
        if self.bend_radius is not None and len(radii) == 1 and radii[0] != self.bend_radius:
            raise ValueError(f"the bend radius options contradict each other: bend_radius {self.bend_radius:g} holds "
                             f"every bend at it, dies [{radii[0]:g}] at {radii[0]:g}. Leave out one of them")
        return self


def _points_form(value: Any) -> str:
    """Which of the two forms ``points`` is (so that errors name only that form's fields)."""
    return "npy" if isinstance(value, (dict, NpyPoints)) else "list"


class UnitConversion(StrictModel):
    """How an uploaded file's coordinates were brought into the request's unit: request value = file value × factor."""

    file_unit: str = Field(description="The file's length unit: mm, cm, m, in, ft, us_ft (US survey foot) or the "
                           "name a CRS gives.")
    request_unit: Units
    factor: Number = Field(gt=0, description="Multiplier from the file's x, y (and z unless z_factor is given) to "
                          "the request's unit; 1 when none was needed.")
    z_file_unit: str | None = Field(default=None, description="The z unit when the file's CRS states a vertical unit "
                                    "other than the horizontal one.")
    z_factor: Number | None = Field(default=None, gt=0, description="Multiplier for z when z_file_unit is given.")
    basis: Literal["options.file_units", "crs", "header", "format", "assumed", "request"] = Field(
        description="Where the file unit came from: the option, the file's CRS, a text file's column header "
        "(`x [m]`, `x_mm`), the format's standard (E57: metres), assumed (a LAS/LAZ file stating no unit: metres), "
        "or none stated (the request's unit).")
    evidence: str = Field(default="", description="What in the file stated it, e.g. 'WKT UNIT[\"US survey foot\", "
                          "0.3048006096012192]' or 'GeoTIFF ProjLinearUnitsGeoKey 9002'.")


class PointSource(StrictModel):
    """What the upload parser read from a point file: set by the upload parser, not needed in JSON bodies."""

    format: str = Field(description="File format read, e.g. 'las', 'ply', 'xyz'.")
    points: StrictInt = Field(ge=0, description="Points kept.")
    units: UnitConversion
    skipped: StrictInt = Field(default=0, ge=0, description="Records (lines, vertices) that could not be read and were "
                         "left out; each is listed in the warnings.")
    skipped_lines: list[StrictInt] = Field(default_factory=list, description="1-based line numbers of the first skipped "
                                     "records (text formats; at most 10).")
    truncated: Flag = Field(default=False, description="The file ends before the records its header declares, or "
                            "mid-record.")
    warnings: list[Diagnostic] = Field(default_factory=list, description="The reader's warnings; the solver adds "
                                       "them to report.warnings.")


class TubeRequest(StrictModel):
    """A scan of one bent tube: unorganised surface samples (full or single-view)."""

    points: Annotated[
        Annotated[list[Point3], Field(json_schema_extra={"minItems": 100}), Tag("list")]
        | Annotated[NpyPoints, Tag("npy")],
        Discriminator(_points_form),
    ] = Field(
        description="Surface samples: a JSON list of [x, y, z], or {\"npy_base64\": ...} holding "
        "an (N, 3) NPY array. At least 100 points; coordinates within 1e12 of the unit."
    )
    units: Units = "mm"
    options: TubeOptions = Field(default_factory=TubeOptions)
    source: PointSource | None = Field(
        default=None, description="What the upload parser read (format, unit conversion, records skipped); set by "
        "the upload parser, not needed in JSON bodies.")


class Segment(BaseModel):
    """One piece of the spine (centreline), in order from the start."""

    type: Literal["line", "arc"]
    start: Vec3 = Field(json_schema_extra=LEN)
    end: Vec3 = Field(json_schema_extra=LEN)
    centre: Vec3 | None = Field(default=None, json_schema_extra=LEN, description="Arc centre (arcs only).")
    radius: float | None = Field(default=None, json_schema_extra=LEN,
                                 description="Arc radius = bend radius (arcs only).")
    angle: float | None = Field(default=None, json_schema_extra=DEG,
                                description="Arc apex angle in degrees (arcs only).")
    normal: Vec3 | None = Field(
        default=None,
        json_schema_extra=unit("1"),
        description="Unit normal of the arc's plane, oriented so that the arc runs from start to "
        "end counter-clockwise about it (arcs only).",
    )


class Residuals(BaseModel):
    """Unsigned point-to-surface distances of the inlier samples (request units)."""

    count: int
    median: float = Field(json_schema_extra=LEN)
    p95: float = Field(json_schema_extra=LEN)
    max: float = Field(json_schema_extra=LEN)
    rms: float = Field(json_schema_extra=LEN)


class Outliers(BaseModel):
    count: int
    indices: list[int] = Field(description="Indices (into the input points) of discarded samples.")
    reasons: list[str] = Field(
        description="Reason per index: every listed sample is far from the fitted surface; the "
        "reason names the first stage that already flagged it: 'local_fit' (curvature off 1/r, "
        "abnormal quadric residual or too few neighbours, §7), 'spine_projection' (MLS projection "
        "distance off the pipe radius, §7) or 'residual' (only the final fit)."
    )
    by_reason: dict[str, int]


class SegmentQuality(BaseModel):
    index: int = Field(description="Index into `segments`.")
    type: Literal["line", "arc"]
    count: int = Field(description="Inlier samples closest to this segment.")
    median: float = Field(json_schema_extra=LEN)
    rms: float = Field(json_schema_extra=LEN)
    max: float = Field(json_schema_extra=LEN)


class BendDeviation(BaseModel):
    bend: int = Field(description="1-based bend number.")
    angle: float = Field(json_schema_extra=DEG, description="measured − nominal bend angle, degrees")
    rotation: float = Field(json_schema_extra=DEG, description="measured − nominal rotation, degrees (wrapped to ±180)")
    length: float = Field(json_schema_extra=LEN, description="measured − nominal straight length before this bend")
    bend_radius: float = Field(json_schema_extra=LEN, description="measured − nominal bend radius")


FIELD_OK = ("Within tolerance: true or false when the samples determine this field, null when they do not (no "
            "verdict either way: see `determined`).")
FIELD_DETERMINED = ("False when the samples do not determine this field (an end straight they stop short on, a bend "
                    "they see from one side, a sigma larger than the tolerance): then `ok` is null, the row "
                    "lists it in `undetermined`, and `bound` or `sigma` says what is known.")


class LengthCheck(BaseModel):
    """One length of one row (straight length, CLR): nominal, measured, deviation (measured − nominal), the
    verdict, and whether the samples determine it."""

    nominal: float = Field(json_schema_extra=LEN)
    measured: float = Field(json_schema_extra=LEN)
    deviation: float = Field(json_schema_extra=LEN)
    tolerance: float = Field(json_schema_extra=LEN)
    ok: bool | None = Field(description=FIELD_OK)
    determined: bool = Field(default=True, description=FIELD_DETERMINED)
    sigma: float | None = Field(default=None, json_schema_extra=LEN, description="Standard deviation of the "
                                "measured value (for an end straight: the samples' spacing at its end).")
    bound: Literal["lower"] | None = Field(default=None, description="'lower': the measured value is a lower "
                                           "bound (the samples end there; the true value may be larger).")


class AngleCheck(BaseModel):
    """One angle of one row (rotation, bend angle), degrees: as :class:`LengthCheck`."""

    nominal: float = Field(json_schema_extra=DEG)
    measured: float = Field(json_schema_extra=DEG)
    deviation: float = Field(json_schema_extra=DEG)
    tolerance: float = Field(json_schema_extra=DEG)
    ok: bool | None = Field(description=FIELD_OK)
    determined: bool = Field(default=True, description=FIELD_DETERMINED)
    sigma: float | None = Field(default=None, json_schema_extra=DEG, description="Standard deviation of the "
                                "measured value.")
    bound: Literal["lower"] | None = Field(default=None, description="'lower': the measured value is a lower "
                                           "bound (a bend seen from one side turns at least this far).")


class InspectionRow(BaseModel):
    """One LRA row checked: straight length before the bend, rotation, bend angle, CLR (the last row: length only)."""

    row: int = Field(description="1-based LRA row, in the nominal's order.")
    length: LengthCheck = Field(description="Request units.")
    rotation: AngleCheck | None = Field(default=None, description="Degrees, deviation wrapped to ±180 (rows 2..n).")
    angle: AngleCheck | None = Field(default=None, description="Degrees (bend rows).")
    bend_radius: LengthCheck | None = Field(default=None, description="Request units (bend rows).")
    failed: list[str] = Field(default_factory=list, description="Determined fields out of tolerance.")
    undetermined: list[str] = Field(default_factory=list, description="Fields the samples do not determine (no "
                                    "verdict on them).")
    ok: bool | None = Field(description="False when a determined field is out of tolerance (`failed`); null when "
                            "none is but a field is not determined (`undetermined`): the row is neither passed nor "
                            "failed; true only when every field is determined and within tolerance.")


class EndPointCheck(BaseModel):
    end: Literal["start", "end"]
    deviation: float = Field(json_schema_extra=LEN, description="Distance of the measured end from the nominal one "
                             "after best-fit alignment, request units.")
    tolerance: float = Field(json_schema_extra=LEN)
    ok: bool | None = Field(description="Within tolerance: true or false when determined, null when not (no verdict "
                            "either way: see `determined`).")
    determined: bool = Field(default=True, description="False when the samples stop short of the nominal end on "
                             "this end's straight (its length is a lower bound), or when the part's end, up to three "
                             "sigmas past the last samples, may lie within the tolerance or beyond it: `ok` is then "
                             "null.")


class SpringbackFit(BaseModel):
    """The bends of one die (one nominal CLR): measured angle = k · commanded angle + b (degrees)."""

    bend_radius: float = Field(json_schema_extra=LEN, description="The die's nominal CLR, request units.")
    bends: list[int] = Field(description="1-based bend numbers.")
    k: float = Field(json_schema_extra=unit("1"), description="Slope, degrees per degree.")
    b: float = Field(json_schema_extra=DEG, description="Degrees.")


class Correction(BaseModel):
    """Values for the next part of one LRA row: deltas to add to the nominal, and the resulting command."""

    row: int
    delta_length: float = Field(json_schema_extra=LEN, description="−(length deviation), request units.")
    delta_rotation: float = Field(json_schema_extra=DEG, description="−(rotation deviation), degrees.")
    delta_angle: float = Field(json_schema_extra=DEG,
                               description="Next command − nominal angle, degrees (the springback to add).")
    springback: float | None = Field(default=None, json_schema_extra=DEG,
                                     description="Commanded − measured bend angle, degrees (bend rows; "
                                     "the nominal is taken as commanded).")
    next: LraRow = Field(description="LRA row to command next (CLR is tooling and stays nominal).")


class Alignment(BaseModel):
    """Rigid motion mapping the nominal frame to the scan: x_scan = R(quaternion) x_nominal + translation."""

    translation: Vec3 = Field(json_schema_extra=LEN)
    quaternion: Quaternion = Field(json_schema_extra=unit("1"), description="[w, x, y, z], w ≥ 0.")


Verdict = Literal["pass", "fail", "not_determined", "not_comparable"]


class Inspection(BaseModel):
    matched: bool = Field(description="False when the bend counts differ (then only sheath data is given).")
    nominal_bends: int = Field(default=0, description="Bends of the nominal.")
    measured_bends: int = Field(default=0, description="Bends reconstructed from the scan.")
    reversed: bool = Field(description="True when the scan was matched to the nominal in reverse direction.")
    measured_lra: list[LraRow] = Field(description="Measured LRA in the nominal's direction.")
    bends: list[BendDeviation]
    last_length: float | None = Field(default=None, json_schema_extra=LEN,
                                      description="measured − nominal length of the last straight")
    sheath_deviation: float = Field(
        json_schema_extra=LEN,
        description="Max distance of the measured centreline from the nominal centreline after best-fit alignment."
    )
    sheath_rms: float = Field(json_schema_extra=LEN)
    alignment: Alignment = Field(description="Rigid motion mapping the nominal frame to the scan.")
    corrected_lra: list[LraRow] = Field(description="LRA to send to the bender (springback correction).")
    tolerances: InspectionTolerances | None = Field(default=None, description="The tolerances applied (defaults "
                                                     "filled in).")
    rows: list[InspectionRow] = Field(default_factory=list, description="Per-row check (bend counts matched only).")
    end_points: list[EndPointCheck] = Field(default_factory=list)
    verdict: Verdict = Field(
        default="fail", description="'pass': every row and end point determined and within tolerance; 'fail': a "
        "determined field or end point out of tolerance (`failed_rows`); 'not_determined': none out of tolerance "
        "but some the samples do not determine (`undetermined_rows`), so the part is neither passed nor failed; "
        "'not_comparable': the nominal's bend count differs from the scan's (`nominal_bends`, `measured_bends`): "
        "no row is compared.")
    failed_rows: list[int] = Field(default_factory=list, description="1-based LRA rows with a determined field out "
                                   "of tolerance.")
    undetermined_rows: list[int] = Field(default_factory=list, description="1-based LRA rows with a field the "
                                         "samples do not determine.")
    corrections: list[Correction] = Field(default_factory=list, description="For the next part (undamped).")
    springback_fits: list[SpringbackFit] = Field(default_factory=list, description="'linear_per_die' only.")
    nominal_source: str = Field(default="nominal", description="How the nominal was given and read.")
    warnings: list[Diagnostic] = Field(default_factory=list, description="Lines of a nominal CSV that were skipped.")


LRA_CONVENTION = (
    "LRA convention: local frame x = initial tangent, y = in-plane normal toward the first bend's "
    "centre, z = x × y; `orientation` maps it to world and `start` is the first end. Each row: go "
    "straight `length`; rotate the in-plane normal about the current tangent by `rotation` (degrees, "
    "right-hand rule); bend by `angle` (degrees) with `bend_radius` toward the normal. n + 1 rows for "
    "n bends, first rotation 0, last row angle 0; bends joined directly have a length-0 row between "
    "them. LRA → XYZ → LRA round trips exactly. A straight tube has no bend plane: then y is an "
    "arbitrary perpendicular. The walking direction starts at the end with the longer end straight "
    "(ties: the larger end bend)."
)


class BendRadiusModel(BaseModel):
    """Which radius model the fit used, and the evidence."""

    chosen: Literal["common", "dies", "nominal_dies", "per_bend", "fixed", "given_dies"] = Field(
        description="'common' one radius for all bends, 'dies' two radii with the bends assigned by the data, "
        "'nominal_dies' one radius per distinct CLR of the nominal (started at those CLRs, each bend on its "
        "nominal bend's die), 'per_bend' a radius per bend, 'fixed' options.bend_radius, 'given_dies' options.dies.")
    criterion: str = Field(description="How it was chosen: 'BIC' (n ln(RSS/n) + p ln n on the inlier surface "
                           "residuals, smaller is better), or 'options' when forced.")
    values: dict[str, float] = Field(default_factory=dict, json_schema_extra=unit("1"),
                                     description="Criterion value per candidate model.")
    rss: dict[str, float] = Field(default_factory=dict, json_schema_extra=unit(LENGTH + "^2"),
                                  description="Sum of squared inlier residuals per candidate.")
    n_parameters: dict[str, int] = Field(default_factory=dict)
    die_radii: list[float] | None = Field(default=None, json_schema_extra=LEN,
                                          description="'dies', 'nominal_dies', 'given_dies': the radius of each die.")
    assignment: list[int] | None = Field(default=None, description="'dies', 'nominal_dies', 'given_dies': the die "
                                         "of each bend.")
    nominal_clrs: list[float] | None = Field(default=None, json_schema_extra=LEN,
                                             description="With a nominal: its distinct CLRs, where the "
                                             "'nominal_dies' candidate started.")
    summary: str = Field(default="", description="Which candidate won and by how much, in words.")


class TubeResult(BaseModel):
    """Reconstructed bent tube: pipe radius, start pose, LRA table, control polygon, spine
    segments, fit quality, outliers, optional inspection, report. See ``lra`` for the LRA
    convention."""

    kind: Literal["tube"] = Field(default="tube", description="The solver kind of this result (what tells the "
                                   "results of GET /v1/jobs/{id}/result apart).")
    pipe_radius: float = Field(json_schema_extra=LEN)
    start: Vec3 = Field(json_schema_extra=LEN, description="World position of the tube start (first end of the centreline).")
    orientation: Quaternion = Field(json_schema_extra=unit("1"), description="Maps the local start frame (see LRA convention) to world, [w,x,y,z].")
    lra: list[LraRow] = Field(description=LRA_CONVENTION)
    control_polygon: list[Vec3] = Field(
        json_schema_extra=LEN,
        description="Start, intersection points of consecutive straights (bends < 180° only), end."
    )
    segments: list[Segment]
    residuals: Residuals
    outliers: Outliers
    segment_quality: list[SegmentQuality] = Field(default_factory=list)
    tolerance: float = Field(json_schema_extra=LEN, description="ε used for the segment count (request units).")
    units: Units = Field(default="mm", description="Unit of every length in the result: the request's. How an "
                         "uploaded file's coordinates were converted into it is in report.details.source.units.")
    inspection: Inspection | None = None
    bend_radius_model: BendRadiusModel | None = Field(default=None, description="The radius model of the bends "
                                                      "and why (null without bends).")
    report: Report
