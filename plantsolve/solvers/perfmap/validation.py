"""The checks of a perfmap request and the job's input they make, once (``SPEC.load``, then ``check_input``): the
request in the solver's units, its setting lines read and checked, and what the reader and the plausibility
checks have to say. The checks at submission, the solve and
the artifacts share it, so the table is prepared once per process, never again by each of them."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np

from plantsolve.schemas.common import Diagnostic
from plantsolve.schemas.perfmap import PerfmapRequest, ResultUnits
from plantsolve.solvers.base import FieldError, InputRejected, StoredInput
from plantsolve.solvers.perfmap.outliers import points_off_their_lines
from plantsolve.solvers.perfmap.plausibility import plausibility_warnings
from plantsolve.solvers.perfmap.speed_names import named_as_speed
from plantsolve.solvers.perfmap.repeats import disagreeing_repeats, identical_lines
from plantsolve.solvers.perfmap.setting_lines import Setting, prepare
from plantsolve.solvers.perfmap.units import (
    UnitError,
    fraction_factor,
    request_conversions,
    speed_unit_error,
    to_internal,
)

FRACTIONS = 1.5  # efficiencies all within this are fractions, whatever unit is stated for them


@dataclass(frozen=True)
class PerfmapInput:
    """What check, solve and artifacts take: ``request`` as submitted, ``internal`` in the solver's units (the
    result's), its ``settings`` prepared, the ``source`` stated in the report and the input's ``warnings``."""

    request: PerfmapRequest
    internal: PerfmapRequest
    units: ResultUnits
    settings: list[Setting]
    source: dict[str, Any] = field(default_factory=dict)
    warnings: list[Diagnostic] = field(default_factory=list)


def file_loc(loc: tuple, rows_of: list[list[int]], values_of: Callable[[int], tuple], what: str = "line",
             ) -> tuple[tuple, str]:
    """A request loc ("positions", i, field, k) as ("file", "row", row, field), where ``rows_of[i][k]`` is the file
    row of point k of position i, and a prefix naming the setting (``values_of(i)``) and its rows."""
    if len(loc) < 2 or loc[0] != "positions" or not isinstance(loc[1], int) or loc[1] >= len(rows_of):
        return ("file",), ""
    i = loc[1]
    rows = rows_of[i]
    where = (f"setting {', '.join(f'{v:g}' for v in values_of(i))} "
             f"({what}s {', '.join(map(str, rows[:12]))}{', ...' if len(rows) > 12 else ''}): ")
    name = loc[2] if len(loc) > 2 and isinstance(loc[2], str) else None
    k = loc[3] if len(loc) > 3 and isinstance(loc[3], int) and loc[3] < len(rows) else 0
    return (("file", "row", rows[k], name) if name else ("file", "row", rows[k])), where


def load(request: PerfmapRequest, source: StoredInput | None = None) -> PerfmapInput:
    """The request converted (``units``, ``options.result_units``) and prepared; raises :class:`InputRejected`
    naming the field of each bad value, and for an upload its place in the file (``file.<path>`` of a JSON file,
    ``file.row.<n>`` or ``file.header`` of a table) or the form's option it came from (:func:`placed`)."""
    try:
        return _load(request, source)
    except InputRejected as error:
        if source is None and not (request.source and request.source.rows):
            raise
        where = request.source.model_dump() if request.source else {}
        if source is None:  # a client's body: only the upload reader says where the form or the file put a value
            where = {k: v for k, v in where.items() if k not in ("form", "document")}
        raise InputRejected([placed(e, where, request.setting_values) for e in error.errors]) from None


def _load(request: PerfmapRequest, source: StoredInput | None) -> PerfmapInput:
    _check_setting_units(request)
    stated, contradicted = _efficiency_unit_against_values(request)
    internal, units = to_internal(stated)
    settings = prepare(internal)
    conversions = [c.model_dump() for c in (request.source.conversions if request.source else [])]
    conversions += request_conversions(stated)
    info: dict[str, Any] = {"format": request.source.format if request.source else "json",
                            "conversions": conversions}
    if source is not None:
        info["file"] = source.name
    rows_of = request.source.rows if request.source and request.source.rows else None
    label = request.source.row_label if rows_of else "line"
    heads = request.source.setting_lines if request.source and request.source.setting_lines else None
    line_notes = disagreeing_repeats(settings, rows_of, label) + identical_lines(settings, rows_of, label, heads)
    line_notes += points_off_their_lines(settings, request, internal, rows_of, label, heads)
    return PerfmapInput(request, internal, units, settings, info,
                        contradicted + plausibility_warnings(internal, units, settings) + line_notes)


def placed(error: FieldError, source: dict[str, Any], setting_of: Callable[[int], tuple],
           lines: dict[tuple, int] | None = None) -> FieldError:
    """A refusal at a request path said where the user wrote the value, for the reader's schema check and the
    checks of :func:`load` alike: at the upload form's field when the form gave it (``source['form']``), in a JSON
    file at its path there (``file.positions.0.flow``, ``file.0.flow`` of a bare list of positions), at a file line
    ``lines`` gives a request path (a map's flow unit), in a table at its row (``file.row.12.flow``, its setting
    named by ``setting_of``) or its header (a unit), else in the file under its request path."""
    loc = tuple(error.loc)
    if loc[:1] == ("file",):
        return error
    path = ".".join(map(str, loc))
    if (form := (source.get("form") or {}).get(".".join(map(str, loc[:2])))) is not None:
        at = (*form, *loc[2:])
        return FieldError(at, error.msg if loc[0] == "options" else f"{'.'.join(map(str, at))}: {error.msg}", error.type)
    if document := source.get("document"):
        written = loc[1:] if document == "positions" and loc[:1] == ("positions",) else loc
        return FieldError(("file", *written), error.msg, error.type)
    if loc[:1] == ("options",):
        return error  # a table or map holds no options: the form's
    if (line := (lines or {}).get(loc[:2])) is not None:
        return FieldError(("file", "line", line), f"line {line}: {path.replace('.', '/')}: {error.msg}", error.type)
    rows = source.get("rows") or []
    if rows and loc[:1] == ("positions",):
        where, prefix = file_loc(loc, rows, setting_of, source.get("row_label") or "line")
        msg = error.msg
        if error.type == "too_short" and len(loc) == 3:  # the three lists of a short setting: its rows
            msg, where = "needs at least 3 measured points (rows)", where[:3]
        return FieldError(where, prefix + msg, error.type)
    at_header = loc[:1] in (("units",), ("setting_units",)) and source.get("format") in ("csv", "xlsx")
    return FieldError(("file", "header") if at_header else ("file",), f"{path}: {error.msg}" if path else error.msg,
                      error.type)


def _check_setting_units(request: PerfmapRequest) -> None:
    """A setting named as a speed whose unit is no speed (``speed [K]``: a temperature column taken for it) is
    refused naming ``setting_units[k]``; the map would be drawn over the wrong quantity."""
    units = request.setting_units or []
    table = bool(request.source and request.source.format in ("csv", "xlsx"))  # units from the header
    errors = [FieldError(("file", "header") if table else ("setting_units", k), message)
              for k, (name, unit) in enumerate(zip(request.setting_names, units))
              if named_as_speed(name) and (message := speed_unit_error(name, unit))]
    if errors:
        raise InputRejected(errors)


def _efficiency_unit_against_values(request: PerfmapRequest) -> tuple[PerfmapRequest, list[Diagnostic]]:
    """A request whose ``units.efficiency`` is a per cent or per mille while every efficiency is a fraction
    already (all within 1.5) is read as fractions, with a warning, instead of being divided again."""
    unit = request.units.efficiency if request.units else None
    try:
        factor = fraction_factor(unit)
    except UnitError:
        return request, []  # to_internal refuses it naming units.efficiency
    values = np.array([v for p in request.positions for v in p.efficiency], dtype=float)
    if factor == 1.0 or not len(values):
        return request, []
    if np.abs(values).max() > FRACTIONS:
        _refuse_mixed(request, unit, values)
        return request, []
    note = Diagnostic(
        code="unit_contradicted_by_values",
        message=f"units.efficiency says {unit!r} but the efficiencies lie in {values.min():.4g}..{values.max():.4g}: "
        f"fractions already, read as they are (not divided by {1 / factor:g} again).",
        details={"field": "units.efficiency", "unit": unit, "values": [float(values.min()), float(values.max())],
                 "reading": "fractions"})
    return request.model_copy(update={"units": request.units.model_copy(update={"efficiency": "1"})}), [note]


def mixed_efficiency_strays(values: np.ndarray, factor: float = 100.0) -> tuple[np.ndarray, bool] | None:
    """Of an efficiency column stated in per cent (``factor`` 100) or per mille (1000), the cells typed in the other
    reading — fractions (at most 1.5) among per cent, or per cent among fractions — and whether they are the
    fractions; None when there are none. The fewer kind is odd only where rescaled it lands among the others
    (within their range widened by 20 %): a real 1.2 % near choke beside 30–94 % is no fraction, nor is 0."""
    fractions = np.abs(values) <= FRACTIONS
    if not fractions.any() or fractions.all():
        return None
    odd_fractions = fractions.sum() <= (~fractions).sum()
    odd = fractions if odd_fractions else ~fractions
    usual = values[~odd]
    rescaled = values * factor if odd_fractions else values / factor
    lo, hi = 0.8 * usual.min(), 1.2 * usual.max()
    strays = odd & (values > 0) & (rescaled >= lo) & (rescaled <= hi)
    return (strays, odd_fractions) if strays.any() else None


def _refuse_mixed(request: PerfmapRequest, unit: str, values: np.ndarray) -> None:
    """Efficiencies in per cent with some typed as fractions (or the other way round): the strays are refused,
    named, since one reading makes them or the others 100 times off."""
    found = mixed_efficiency_strays(values, 1 / fraction_factor(unit))
    if found is None:
        return
    strays, odd_fractions = found
    usual = values[(np.abs(values) <= FRACTIONS) != odd_fractions]
    kind = "a fraction among per cent" if odd_fractions else "a per-cent value among fractions"
    errors = []
    flat = iter(strays)
    for i, p in enumerate(request.positions):
        for k, v in enumerate(p.efficiency):
            if next(flat) and len(errors) < 10:
                errors.append(FieldError(("positions", i, "efficiency", k), (
                    f"efficiency {v:g} where units.efficiency is {unit!r} and the other values lie in "
                    f"{usual.min():.4g}..{usual.max():.4g}: {kind}? Write them in one unit")))
    raise InputRejected(errors)


def loaded(value: PerfmapRequest | PerfmapInput) -> PerfmapInput:
    """A loaded input from either (library use and tests pass the request itself)."""
    return value if isinstance(value, PerfmapInput) else load(value)


def check_input(value: PerfmapRequest | PerfmapInput) -> None:
    """The checks across fields (units included), raising :class:`InputRejected` naming each bad field: loading
    runs them, so a loaded input has passed them."""
    loaded(value)
