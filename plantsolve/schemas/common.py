"""Building blocks shared by every solver's request and result models.

Conventions (they hold for every solver):
- lengths are in the request's ``units`` (default ``"mm"``);
- angles are in **degrees** in every public schema (solvers work in radians inside);
- quaternions are ``[w, x, y, z]`` (scalar first), unit norm, active rotation;
- every float in a request must be finite: NaN and infinity are rejected with a 422
  that names the field;
- every yes/no in a request is JSON's ``true`` or ``false`` (:data:`Flag`): ``1``, ``"yes"``, ``"on"`` are refused
  with a 422 that names the field, whichever way the request came;
- every number in a request is a number (:data:`Number`): ``true``, ``false`` and strings are refused with a 422
  that names the field, whichever way the request came (a body, an uploaded file, a form's options); only an option
  an upload form may type as text is read from one (``"6"``, :func:`plain_numbers`).
"""

from __future__ import annotations

import json
import re
from collections.abc import Iterable, Mapping
from numbers import Integral, Real
from types import MappingProxyType
from typing import Annotated, Any, Literal

from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, Strict, ValidationInfo, computed_field, \
    field_validator
from pydantic_core import PydanticCustomError

def json_integer(value: Any) -> Any:
    """JSON Schema's integer: a number without a fraction (``5`` and ``5.0``), never a bool or a string."""
    if isinstance(value, bool) or not isinstance(value, Real):
        raise PydanticCustomError("int_type", "Input should be a valid integer")
    if isinstance(value, Integral):
        return int(value)
    if not float(value).is_integer():
        raise PydanticCustomError("int_from_float", "Input should be a valid integer, got a number with a fractional part")
    return int(value)


Integer = Annotated[int, BeforeValidator(json_integer)]
"""An integer field of a request: 5 or 5.0, as JSON Schema's ``integer``; requests are validated strictly
otherwise (no ``true`` for 1, no ``"5"`` for 5). Bounds go before the validator, or the schema loses them:
``Annotated[int, Field(ge=0), BeforeValidator(json_integer)]``."""

Number = Annotated[float, Strict()]
"""A number of a request: a JSON number (``6``, ``6.0``, ``-1e3``), never ``true``/``false`` nor a string. Strict,
because an uploaded .json file and an upload form's options are validated from parsed JSON in pydantic's lax mode,
where a bare float reads ``true`` as 1.0 (a JSON body is validated strictly as a whole); the strict check is pydantic's
own, in its compiled core, so a million-point array costs no more than before. An option a form may type as text
("6") is read by :func:`plain_numbers`. The number types below are made of it."""

def json_boolean(value: Any) -> Any:
    """JSON's ``true`` or ``false``; anything else a 422 saying which two values a yes/no takes."""
    if not isinstance(value, bool):
        raise PydanticCustomError("bool_type", "Input should be true or false (JSON's booleans; not {value})",
                                  {"value": json_text(value)})
    return value


def json_text(value: Any) -> str:
    """A refused value as the JSON that holds it (``"yes"``, ``1``), cut at 40 characters."""
    try:
        text = json.dumps(value, ensure_ascii=False)
    except (TypeError, ValueError):
        text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


Flag = Annotated[bool, Strict(), BeforeValidator(json_boolean)]
"""A yes/no of a request: JSON's ``true`` or ``false``, nothing else. Strict for the reason :data:`Number` is: in lax
mode (an uploaded .json file, a form's options) pydantic reads ``1``, ``0``, ``"yes"``, ``"on"``, ``"true"`` and
``"1"`` as booleans, so a ``"no"`` meant as a word, or a count of 1, silently switched an option. Every bool of a
request is one of these (a test walks the request models)."""

FiniteFloat = Annotated[Number, Field(allow_inf_nan=False)]
"""A number that must be finite (NaN and +-inf are rejected)."""

Vec3 = Annotated[list[FiniteFloat], Field(min_length=3, max_length=3)]
# Input magnitudes a plant model can have: coordinates within 1e12 of the unit (a light-hour in mm),
# direction components within 1e9 (they are normalised; 1e200 only overflows the solvers' products).
MAX_COORDINATE = 1e12
Coordinate = Annotated[Number, Field(allow_inf_nan=False, ge=-MAX_COORDINATE, le=MAX_COORDINATE)]
MAX_MEASURED = 1e12
Measured = Annotated[Number, Field(allow_inf_nan=False, ge=-MAX_MEASURED, le=MAX_MEASURED)]
"""A measured value (flow, pressure, a setting) within 1e12 of its unit: beyond that only overflows."""
Point3 = Annotated[list[Coordinate], Field(min_length=3, max_length=3)]
DirectionComponent = Annotated[Number, Field(allow_inf_nan=False, ge=-1e9, le=1e9)]
Direction3 = Annotated[list[DirectionComponent], Field(min_length=3, max_length=3)]
"""A point or a direction ``[x, y, z]``."""

Quaternion = Annotated[list[FiniteFloat], Field(min_length=4, max_length=4)]
"""A rotation quaternion ``[w, x, y, z]`` (scalar first)."""

UnitName = Literal["mm", "cm", "m", "in", "ft"]
"""The canonical name of a request's length unit (the OpenAPI enum)."""

_PLAIN_NUMBER = re.compile(r"\s*[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?\s*")


def option_number(value: Any, info: ValidationInfo | None = None) -> Any:
    """A number of the request: a JSON number, or a string of one as an upload form's options are typed (``"6"``
    is the same 6, so it is read, as a float for the strict number type to take). ``true`` and ``false`` are no number
    (read as 1 and 0 they made a tube's tolerance of 1 mm and an alignment's position tolerance of 1 unit without a
    word), nor is a string only Python reads as one (``"6_0"`` is 60 to it). A JSON body (validated in JSON mode) is
    held to its schema: there a string stays a string, which the number type refuses."""
    if isinstance(value, bool):
        raise PydanticCustomError("float_type", "Input should be a number, not true or false")
    if isinstance(value, str) and (info is None or info.mode != "json"):
        if not _PLAIN_NUMBER.fullmatch(value):
            raise PydanticCustomError("float_parsing", "Input should be a number (digits, a point, an exponent)")
        return float(value)
    return value


def plain_numbers(*fields: str):
    """A model's before-validator holding ``fields`` (numbers, or lists of numbers) to :func:`option_number`: the
    fields an upload form may type as text; a validator of the field, not of its type, so that the JSON schema keeps
    the field's bounds."""

    def check(cls, value: Any, info: ValidationInfo) -> Any:
        if isinstance(value, list):
            return [option_number(item, info) for item in value]
        return option_number(value, info)

    return field_validator(*fields, mode="before")(check)


UNIT_SPELLINGS: Mapping[str, tuple[str, ...]] = MappingProxyType({
    "mm": ("mm", "millimetre", "millimetres", "millimeter", "millimeters"),
    "cm": ("cm", "centimetre", "centimetres", "centimeter", "centimeters"),
    "m": ("m", "metre", "metres", "meter", "meters"),
    "in": ("in", "inch", "inches"),
    "ft": ("ft", "foot", "feet"),
})
"""The words and symbols (lower case, read in any case) that name each request unit: the one table of them, which
the readers of files (``solvers.length_units``) extend with the units only a file states."""

MICROMETRE_SPELLINGS = ("um", "µm", "μm", "micrometre", "micrometres", "micrometer", "micrometers", "micron", "microns")
"""Micrometres, as an FE or CMM export names them (the micro sign and the Greek mu both occur): a unit a file's
coordinates may be in, which no request is written in."""

FILE_UNIT_SPELLINGS: Mapping[str, tuple[str, ...]] = MappingProxyType({**UNIT_SPELLINGS, "um": MICROMETRE_SPELLINGS})
"""Every length unit a file may state, and its spellings: the request units and micrometres. The readers' table of
sizes (``solvers.length_units.SIZES``) has exactly these units."""

AMBIGUOUS_UNITS: Mapping[str, str] = MappingProxyType({
    "Mm": "the megametre (in SI, M is mega) or millimetres typed with a slipped shift key"})
"""Spellings that name a unit in one reading and another unit in another, with both readings."""

_UNIT_OF_SPELLING = {spelling: name for name, spellings in FILE_UNIT_SPELLINGS.items() for spelling in spellings}


def spelled_unit(word: Any) -> Any:
    """The canonical unit name ``word`` spells ('MM', 'Millimetres', ' IN ', 'µm' → 'mm', 'mm', 'in', 'um'); a value
    error naming both readings for 'Mm'; anything else unchanged, for the enum to refuse by its own rule."""
    if not isinstance(word, str):
        return word
    if word.strip() in AMBIGUOUS_UNITS:
        raise PydanticCustomError(
            "ambiguous_unit", "'{word}' reads as {readings}; write mm for millimetres (no request is in megametres)",
            {"word": word.strip(), "readings": AMBIGUOUS_UNITS[word.strip()]})
    return _UNIT_OF_SPELLING.get(word.strip().lower(), word)


def spelled_request_unit(word: Any) -> Any:
    """:func:`spelled_unit` for a request's unit, which is never micrometres: those are refused saying so (the
    enum's own message would list the units, as if 'µm' were a typing slip)."""
    unit = spelled_unit(word)
    if isinstance(unit, str) and unit not in UNIT_SPELLINGS and unit in FILE_UNIT_SPELLINGS:
        raise PydanticCustomError(
            "literal_error", "'{word}' is micrometres, a unit only a file's coordinates may be in (a tube scan's "
            "options.file_units); this unit is one of {units}", {"word": str(word).strip(), "units": ", ".join(
                UNIT_SPELLINGS)})
    return unit


Units = Annotated[UnitName, BeforeValidator(spelled_request_unit)]
"""Length unit of a request; results are given in the same unit. A request may spell it in any case and by its name
('MM', 'Millimetres', 'IN'); the OpenAPI document lists the canonical names, which every result gives."""

FileUnitName = Literal["mm", "cm", "m", "in", "ft", "um"]
"""The canonical name of a length unit a file's coordinates may be in (the OpenAPI enum)."""

FileUnits = Annotated[FileUnitName, BeforeValidator(spelled_unit)]
"""The length unit of a file's coordinates, where its reader converts every unit of :data:`FILE_UNIT_SPELLINGS`
(a tube scan's): the request's units and micrometres ('um', 'µm', 'μm', 'microns'), in any case."""

LENGTH = "{units}"
"""The unit of a result's lengths: the result's own ``units`` field (the request's length unit)."""


def unit(symbol: str) -> dict[str, str]:
    """The unit of a result field as the OpenAPI document states it: ``{"x-unit": symbol}``.

    ``symbol`` is a unit expression pint reads (``"V"``, ``"m/s"``, ``"deg"``, ``"1"`` for a pure number or a
    fraction), in which ``{name}`` stands for the unit held by the result's field ``name`` (dotted for a nested
    one): ``unit(LENGTH)``, ``unit(LENGTH + "^3")``, ``unit("{units.flow}")``. Pass it as a field's
    ``json_schema_extra``; every number of every result carries one (a test walks the result schemas).
    """
    return {"x-unit": symbol}


class StrictModel(BaseModel):
    """Base of request models: unknown fields are an error, not silently dropped."""

    model_config = ConfigDict(extra="forbid")


class Diagnostic(BaseModel):
    """One warning or finding, for people (``message``) and machines (``code``, ``details``)."""

    code: str = Field(description="Stable machine-readable identifier, e.g. 'not_converged'.")
    message: str = Field(description="One human sentence.")
    details: dict[str, Any] = Field(default_factory=dict)


VERDICT_CODES: dict[str, str] = {
    "inspection_failed": "FAIL",
    "inspection_not_determined": "NOT DETERMINED",
    "inspection_not_comparable": "NOT COMPARABLE",
    "volume_not_determined": "NOT DETERMINED",
    "totals_not_determined": "NOT DETERMINED",
    "rigidity_not_determined": "NOT DETERMINED",
    "one_piece_not_determined": "NOT DETERMINED",
    "submodels_missing": "NOT DETERMINED",
    "not_converged": "NOT CONVERGED",
    "verification_failed": "VERIFICATION FAILED",
    "tolerance_not_reached": "TOLERANCE NOT REACHED",
}
"""The warning codes that are a verdict against a result, each with its headline. Most warnings are caveats on an
answer that stands (a file's unit converted, a fit less close); these say the answer is *no* or *not known*: a tube
out of tolerance or not measurable against its nominal, a zone whose volume is not known (or totals of a file cut short: not the building's), a fit stopped before it converged, an optimized model that
failed its own verification, an accuracy asked for and not reached, a LEGO model mostly of parts not in the catalogue,
one that comes apart as analysed (loose as drawn or held by joints the catalogue lacks: not known which), or one that
places sub-models its file does not hold."""


class ReportVerdict(BaseModel):
    """A warning of the report that says the result does not pass what was asked."""

    label: str = Field(description="The verdict in a word or two: FAIL, NOT DETERMINED, NOT CONVERGED, ...")
    code: str = Field(description="The warning's code, one of the verdict codes.")
    message: str = Field(description="The warning's sentence.")


def verdicts_of(warnings: Iterable[Any] | None) -> list[ReportVerdict]:
    """The warnings (``Diagnostic`` models, or dicts as a report is stored) that are verdicts, in their order."""
    found = []
    for warning in warnings or ():
        code, message = ((warning.get("code"), warning.get("message")) if isinstance(warning, Mapping)
                         else (warning.code, warning.message))
        if code in VERDICT_CODES:
            found.append(ReportVerdict(label=VERDICT_CODES[code], code=code, message=str(message or "")))
    return found


class Report(BaseModel):
    """What a solver says about its run.

    On success: ``status`` is ``"ok"`` or ``"warning"`` with the warnings and diagnostics, and ``verdict`` says
    whether one of the warnings is a verdict against the result (the job ran to its end; its answer is no).
    On failure: ``status`` is ``"failed"``, ``stage`` names the stage that failed,
    ``message`` is a human sentence and ``details`` carries the machine-readable facts.
    """

    status: Literal["ok", "warning", "failed"] = "ok"
    stage: str | None = Field(default=None, description="Solver stage that failed (failures only).")
    message: str = ""
    warnings: list[Diagnostic] = Field(default_factory=list)
    details: dict[str, Any] = Field(default_factory=dict)

    @computed_field(description="The first warning that is a verdict against the result (a failed or undetermined "
                                "inspection, a fit not converged, a verification failed, a tolerance not reached: a "
                                "kind puts its gravest first); null when the result stands or the run failed.")
    @property
    def verdict(self) -> ReportVerdict | None:
        if self.status == "failed":
            return None
        return next(iter(verdicts_of(self.warnings)), None)
