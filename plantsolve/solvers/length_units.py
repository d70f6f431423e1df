"""Length units: one vocabulary of their names, sizes and spellings for every kind's readers and checks.

A unit has one canonical name (the request's ``units`` words of ``schemas.common.Units``, and ``um`` for the
micrometres an FE tool's export may state) and the spellings a file or header writes it in, read in any case
('MM', 'Meters'). A reader takes the names it can convert to (``among``); what a file format adds of its own
(the LAS/GeoTIFF US survey foot, a PLY comment's letters-only words) stays with that reader. Plain tables and
pure functions: nothing here changes after import, and nothing imports pint (a table of six sizes does not
need a unit registry's import time).
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from types import MappingProxyType

from plantsolve.schemas.common import AMBIGUOUS_UNITS, FILE_UNIT_SPELLINGS, spelled_unit

# metres per unit of each request unit (schemas.common.Units)
METRES = MappingProxyType({"mm": 1e-3, "cm": 1e-2, "m": 1.0, "in": 0.0254, "ft": 0.3048})
# ... and of every unit named here: files may state micrometres, which no request is written in
SIZES = MappingProxyType({**METRES, "um": 1e-6})

# the words and symbols that name each unit (lower case): the schema's table (the request units, which it reads in a
# JSON body, and micrometres, which a tube scan's file_units takes; the micro sign and the Greek mu both occur)
SPELLINGS = FILE_UNIT_SPELLINGS
_NAMED = MappingProxyType({spelling: unit for unit, spellings in SPELLINGS.items() for spelling in spellings})


def unit_named(word: str, among: Iterable[str] = METRES) -> str | None:
    """The canonical name of the unit ``word`` spells (in any case, blanks around it ignored) when it is one of
    ``among`` (default: the request's units), else None; None for a spelling of two readings ('Mm', which
    ``two_readings`` names), as a JSON body's ``units`` refuses it."""
    if two_readings(word) is not None:
        return None
    unit = _NAMED.get(word.strip().lower())
    return unit if unit is not None and unit in among else None


def two_readings(word: str) -> str | None:
    """Why a file's ``word`` names no one unit ("'Mm' reads as the megametre ... or millimetres ..."), the
    schema's rule for a JSON body's ``units``; None for any other word."""
    readings = AMBIGUOUS_UNITS.get(word.strip())
    return None if readings is None else f"{word.strip()!r} reads as {readings}; write mm for millimetres"


def spellings(among: Iterable[str] = METRES) -> frozenset[str]:
    """Every spelling (lower case) of the units ``among``."""
    return frozenset(s for unit in among for s in SPELLINGS[unit])


def unit_of_size(metres: float, among: Iterable[str] = METRES) -> str | None:
    """The unit among ``among`` that is ``metres`` long (to 1e-9, as a file's stated factor is rounded), or None."""
    return next((unit for unit in among if abs(SIZES[unit] - metres) <= 1e-9 * SIZES[unit]), None)


def request_unit(word: object, among: Iterable[str] = METRES) -> str:
    """The unit among ``among`` (default: the request's units, ``METRES``) a form's or a file's ``word`` spells in any
    case ('MM', 'Millimetres', 'IN', and 'µm' or 'microns' when ``among`` holds micrometres), as a JSON request's
    ``units`` reads it; ValueError saying why for a spelling of two readings ('Mm') or of no unit among them."""
    unit = spelled_unit(word)  # a ValueError naming both readings of 'Mm'
    if isinstance(unit, str) and unit in among:
        return unit
    named = unit_named(word, among) if isinstance(word, str) else None
    if named is None:
        raise ValueError(f"unknown unit {word!r}; one of {', '.join(among)} (or their names: millimetres, inches, ...)")
    return named


# A comment that states the coordinates' unit, as scanners and converters write one before the data (``# units: in``,
# ``comment Unit = meter``, ``obj_info length_unit millimetres``): the word ``unit(s)``, a separator (a colon, an
# equals sign or a blank: without one, ``# units``, ``# unitless`` and ``# Unity`` were read as stating the units
# 's', 'less' and 'y') and one word of letters, or the micro sign's 'µm'
COMMENT_UNIT = re.compile(r"(?:length[_ ]?)?units?(?:\s*[:=]\s*|\s+)([a-zµμ]+)\s*$", re.IGNORECASE)
# the words by which a comment says no unit is stated
NO_UNIT = frozenset({"none", "unknown", "unitless", "undefined", "unspecified", "arbitrary", "na", "n", "default"})


def comment_unit(text: str, among: Iterable[str] = METRES) -> tuple[str, str | None] | None:
    """What the comment ``text`` (its marker taken off: ``units: in``) states of the coordinates' unit: the word
    and the unit among ``among`` it names (None: a unit not among them, or a spelling of two readings, which
    ``two_readings`` names); None when it states none (another comment, or a word of :data:`NO_UNIT`)."""
    match = COMMENT_UNIT.fullmatch(text.strip())
    if match is None or match.group(1).lower() in NO_UNIT:
        return None
    return match.group(1), unit_named(match.group(1), among)
