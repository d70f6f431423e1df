"""Units of a rig table's quantities, read with pint (one registry for the whole package).

What exporters write is accepted: ``m3/h``, ``m^3/s``, ``m³/s``, ``%``, ``kg/s``, ``lbm/s``, ``°C``/``degC``,
``rpm``, ``1/min``, ``psi``/``psia``/``psig``, ``-`` for dimensionless, in brackets or parentheses or after a
comma (the caller strips those). Each measured quantity has the dimensions it may take
(:data:`ALLOWED`); a unit of other dimensions (``kg`` for a flow) is refused naming the column.

The solver's internal units: flow and pressure stay in the unit they were submitted in (every error the
solver reports is relative and every geometric step range-normalised, so a unit is a label to them), unless
``options.result_units`` asks for another unit of the same dimensions, to which the values are converted;
efficiency is a fraction (``%`` and ``‰`` are divided out); settings keep their submitted units (labels).
"""

from __future__ import annotations

import functools
import itertools
import math
import re
from dataclasses import dataclass

import pint

from plantsolve.schemas.perfmap import PerfmapRequest, QuantityUnits, ResultUnits, ResultUnitsOption
from plantsolve.solvers.base import FieldError, InputRejected

# Spellings of rig software and cycle codes that pint does not know (pint has ‰ as 'permille' already:
# defining it again logs a redefinition warning on every run).
_DEFINITIONS = ("lbm = pound", "psia = psi", "psig = psi", "mmWC = mmH2O", "mWC = 1000 * mmH2O", "barg = bar",
                "bara = bar", "mbarg = millibar", "kPag = kilopascal", "MPag = megapascal",
                # fan and pump rigs' volume flows: pint read 'cfm' as centifermis, a length
                "cfm = foot ** 3 / minute", "acfm = foot ** 3 / minute", "gpm = gallon / minute",
                # vacuum and fan rigs' pressures: pint has 'torr' but not 'Torr' (so no 'mTorr', read as megatorr or
                # millitorr), nor water gauge as US fan tables (in. WG, WC) and Japanese ones (mmAq) write it
                "Torr = torr", "inWC = inH2O", "inWG = inH2O", "mmWG = mmH2O", "mmAq = mmH2O",
                # engine decks' pounds per second ('Wc [pps]'): pint read it as pico-parsec-seconds, refused as a length
                "pps = pound / second")
# Volumes at standard or normal conditions: a mass flow in volume units, which no factor makes an actual volume flow.
# Normal or standard litres ('Nl/min', 'SLPM', 'sccm') too: re-cased, 'NL/MIN' read as nanolitres, 1e6 too small.
_CUBED = r"(?:3|\^3|³|\*\*3)"
_PER_TIME = r"(?:h|hr|hour|s|sec|m|min|d|day)"
_STANDARD_VOLUMES = re.compile(
    rf"(?:k|m|mm)?(?:s|std\s*)(?:cf|ft{_CUBED})\s*(?:[mhsd]|/\s*{_PER_TIME})"
    rf"|k?[ns]\s*(?:m{_CUBED}|l|ml|cm{_CUBED}|cc)\s*/\s*{_PER_TIME}|[ns]lp[mhs]|[ns]lm|scc[ms]", re.IGNORECASE)


@functools.cache
def registry() -> pint.UnitRegistry:
    """The one unit registry (built on first use: it takes a few hundred milliseconds; read-only after)."""
    reg = pint.UnitRegistry(autoconvert_offset_to_baseunit=True)
    for definition in _DEFINITIONS:
        reg.define(definition)
    return reg

MEASURED = ("flow", "pressure", "efficiency")
# Dimensions each measured quantity may have, in words for the messages.
ALLOWED = {
    "flow": {"[mass] / [time]": "mass flow (kg/s, lbm/s)", "[length] ** 3 / [time]": "volume flow (m3/h, m³/s)",
             "": "dimensionless (corrected or relative flow, %)"},
    "pressure": {"[mass] / [length] / [time] ** 2": "pressure (Pa, kPa, bar, psi)", "": "ratio (PR, -)",
                 "[length]": "head (m)", "[length] ** 2 / [time] ** 2": "specific work (J/kg)"},
    "efficiency": {"": "fraction or percent (-, %)"},
}
# Gauge pressures are above the ambient, which no file states: converting one to an absolute unit (or back)
# with a factor alone would shift every value by about an atmosphere without a word.
GAUGE = frozenset({"barg", "psig", "mbarg", "kPag", "MPag"})
# A pressure marked absolute or gauge as rig sheets and process data sheets write it: 'kPa(a)', 'bar (abs)', 'psi(g)',
# 'kPa gauge'. Read bare, 'kPa(a)' lost its closing bracket and pint refused it, while 'psia' and 'bara' passed.
# A lone letter after a space is a mark too ('bar g', 'kPa a', 'psi G': pint read 'bar g' as bar times grams, a refusal
# naming mass squared), and so is a capital glued to a unit written in its own case ('MPaA', 'kPaA': Asian process
# data sheets write gauge and absolute so, as 'MPaG').
_PRESSURE_MARK = re.compile(r"(?P<unit>[A-Za-z]+)\s*(?:\(\s*(?P<mark>a|abs|g|gauge)\s*\)|\s(?P<word>abs|gauge|a|g))",
                            re.IGNORECASE)
_GLUED_MARK = re.compile(r"(?P<unit>[A-Za-z]*[a-z])(?P<word>[AG])")
_GAUGE_OF = {"bar": "barg", "psi": "psig", "mbar": "mbarg", "kPa": "kPag", "MPa": "MPag"}
# Units whose dimensions a setting named as a speed may have: relative (fraction, %), rotational (rpm, 1/s,
# rad/s) or corrected rotational (rpm/sqrt(K)).
SPEED_DIMENSIONS = {"1": "relative (fraction, %)", "rpm": "rotational (rpm, 1/min, rad/s)",
                    "rpm / K ** 0.5": "corrected (rpm/K^0.5)"}
# What another column of a rig file holds (a temperature, a pressure, a mass, a length, a flow, a time): a speed
# setting in one of these units is that column taken for the speed. Any other unit stays a label: cycle codes
# write corrected speeds in units pint reads otherwise ('rpm/R^0.5' in Rankine, where pint's R is the gas constant).
OTHER_QUANTITIES = ("K", "Pa", "kg", "m", "kg/s", "m^3/s", "s")
_DIMENSIONLESS_WORDS = {"", "-", "–", "1", "—", "/", "ratio", "dimensionless", "frac", "fraction", "n/a", "na"}
# Exponents written as plain digits after a length ('m3/h', 'cm3/s', 'ft3/min').
# 'pounds mass' and 'pound-force' as data sheets spell them out: pint would read 'mass' as milli-arcseconds
_POUND_WORDS = re.compile(r"\bpounds?[\s_-]*(?P<kind>mass|force)\b", re.IGNORECASE)
_DIGIT_EXPONENT = re.compile(r"(?<![A-Za-z])(m|cm|mm|dm|ft|in|l)([23])(?![0-9])", re.IGNORECASE)
# What a rig file's columns hold: a unit written in another case ('KG/S', 'KPA', 'M3/H') is re-cased only into one of
# these, so that 'KG' is kilograms and not kilogauss, 'PA' pascals and not petaamperes.
_RIG_UNITS = ("kg/s", "m^3/s", "Pa", "m", "J/kg", "1", "1/s", "rpm/K^0.5", "K", "kg", "s", "W")
_LONGEST_RECASED = 10  # letters of a word whose every casing is tried (2^10 spellings at most)
_SUB_MILLI = frozenset({"micro", "nano", "pico", "femto", "atto", "zepto", "yocto", "ronto", "quecto"})
# 'micron' under a pressure: a head in micrometres to pint, but vacuum gauges' micron is the micrometre of mercury.
_MICRON = re.compile(r"microns?", re.IGNORECASE)


class UnitError(ValueError):
    """A unit that is not understood or has the wrong dimensions for its quantity."""


class AmbiguousUnit(UnitError):
    """A unit written in a casing that reads as two units of the quantity ('MPA': MPa or mPa)."""


class StandardVolume(UnitError):
    """A volume flow at standard or normal conditions ('Nm3/h', 'nl/min', 'SCFM'): a unit, but of a mass flow that
    no factor converts without the reference state."""


@dataclass(frozen=True)
class Unit:
    """A parsed unit: its canonical spelling (what results state) and its pint unit."""

    text: str
    unit: pint.Unit

    @property
    def dimensionless(self) -> bool:
        return self.unit.dimensionless

    def factor_to(self, other: "Unit") -> float:
        return float(registry().Quantity(1.0, self.unit).to(other.unit).magnitude)


# the longest text read as a unit (the longest real ones, 'pound / second ** 1', are a third of it)
LONGEST_UNIT = 64


def parse_unit(text: str, dimensions: frozenset[str] | None = None) -> Unit:
    """A unit as exporters write it; raises :class:`UnitError` when pint cannot read it. Units are case-sensitive
    ('MPa' is not 'mPa'), but one that pint cannot read as written, or that lacks ``dimensions`` (those of
    :func:`_dimensions`) when they are given, is read in the one casing that has them ('KG/S' is kg/s, 'PA' under a
    pressure Pa), and refused when two casings do ('MPA': MPa or mPa). A text longer than ``LONGEST_UNIT`` is no
    unit: it is refused before pint and the casings are tried on it (a pasted paragraph took seconds)."""
    if len(text) > LONGEST_UNIT:
        raise UnitError(f"unit text of {len(text):,} characters ({text[:20]!r}…) is no unit: units are at most "
                        f"{LONGEST_UNIT} characters ('kg/s', 'ft**3/min', 'kPa(a)')")
    marked = _marked_pressure(text.strip().strip("[]").strip())
    if marked is not None:
        return marked
    s = text.strip().strip("[]()").strip()
    if s.lower() in _DIMENSIONLESS_WORDS:
        return Unit("1", registry().dimensionless)
    if s.lower() == "pct":  # per cent as tables abbreviate it; pint reads a picocarat (a mass)
        s = "percent"
    if _STANDARD_VOLUMES.fullmatch(s):
        raise StandardVolume(f"unit {text.strip()!r} is a volume flow at standard (normal) conditions, a mass flow in "
                        "volume units: no factor makes it an actual volume flow without those conditions; convert "
                        "it to a mass flow (kg/s) or state the actual volume flow (m3/h, acfm)")
    s = (s.replace("·", "*").replace("⋅", "*").replace("°C", "degC").replace("°F", "degF")
         .replace("° C", "degC").replace("deg C", "degC").replace("deg F", "degF"))
    s = _POUND_WORDS.sub(lambda m: "lbm" if m["kind"].lower() == "mass" else "lbf", s)
    s = _DIGIT_EXPONENT.sub(r"\1**\2", s)
    s = s.replace("^", "**")
    unit = _pint_unit(s)
    if unit is None or (dimensions is not None and _dimensions(unit) not in dimensions):
        unit = _recased(text.strip(), s, dimensions or _rig_dimensions()) or unit
    if unit is None:
        raise UnitError(f"unit {text.strip()!r} is not understood (write e.g. kg/s, m3/h, bar, kPa, psi, %, rpm)")
    if unit.dimensionless and str(unit) == "dimensionless":
        return Unit("1", unit)
    return Unit(format(unit, "~P") or "1", unit)


def _pint_unit(text: str) -> pint.Unit | None:
    try:
        return registry().parse_units(text)
    except Exception:  # pint's parser raises many types on garbage (tokenize, syntax, key, attribute errors)
        return None


@functools.cache
def _rig_dimensions() -> frozenset[str]:
    return frozenset(_dimensions(registry().parse_units(u.replace("^", "**"))) for u in _RIG_UNITS)


def _casings(word: str) -> list[str]:
    """The spellings of ``word`` in every casing that pint reads as a unit name."""
    if len(word) > _LONGEST_RECASED:
        tried = {word, word.lower(), word.upper(), word.title()}
    else:
        tried = {"".join(c) for c in itertools.product(*({ch.lower(), ch.upper()} for ch in word))}
    return [spelling for spelling in sorted(tried) if registry().parse_unit_name(spelling)]


def _lowered_into_sub_milli(word: str, spelling: str) -> bool:
    """Whether ``spelling`` lowers the leading capital of ``word`` into a prefix below milli: a capital there is the
    N or S of normal and standard volumes ('NL/MIN'), not a nano or pico, which would read values a million times
    too small without a word. A capital U is the exception: upper case has no µ, and 'U' is how it writes micro
    ('UMHG' is µmHg, as 'umHg' is)."""
    if word[0] == "U" and spelling[0] == "u":
        return False
    return word[0].isupper() and spelling[0].islower() and all(
        prefix in _SUB_MILLI for prefix, _, _ in registry().parse_unit_name(spelling))


# Prefixes a capital gives in a re-cased unit that no instrument puts on a head (mmHg, inH2O, mmWC), on torr or on a
# gauge unit: 'MMHG' is mmHg and 'MTORR' mTorr (vacuum gauges' upper-case displays and exports), never megametres of
# mercury (1.3 million bar) or megatorr. A megabar is a unit in use, so 'MBAR' (Mbar or mbar) stays refused.
_UPWARD_PREFIXES = frozenset({"mega", "giga", "tera", "peta", "exa", "zetta", "yotta", "ronna", "quetta"})
_UNSCALED = frozenset({"torr", "Torr", "mWC", "mmWC", "inWC", "inWG", "mmWG", "mmAq", "standard_atmosphere",
                       "technical_atmosphere"}) | GAUGE | {"barg"}


def _scaled_up_unscalable(spelling: str) -> bool:
    """Whether pint reads ``spelling`` only as a head, torr or gauge unit under a prefix of mega or more."""
    readings = registry().parse_unit_name(spelling)
    return bool(readings) and all(
        (prefix in _UPWARD_PREFIXES and (name in _UNSCALED or name.endswith(("_Hg", "_H2O")) or "_H2O_" in name))
        or (prefix and name.startswith(("inch_", "foot_")))  # 'MINHG' is no milli-inch of mercury either
        for prefix, name, _ in readings)


_WORD = re.compile(r"[A-Za-z][A-Za-z0-9]*")  # 'H2O' one word: 'INH2O' is inH2O


def _respelled(text: str, words: tuple[str, ...]) -> str:
    """``text`` with its words (:data:`_WORD`) replaced by ``words`` in order."""
    replacing = iter(words)
    return _WORD.sub(lambda _: next(replacing), text)


def _recased(written: str, text: str, dimensions: frozenset[str]) -> pint.Unit | None:
    """The unit ``text`` is in the one casing of its words that has ``dimensions``; None when none has; raises
    :class:`UnitError` when casings of other magnitude do (``written`` as the file wrote it, for the message)."""
    words = _WORD.findall(text)
    if not words:
        return None
    choices = [_casings(w) for w in words]
    if not all(choices) or math.prod(map(len, choices)) > 256:
        return None
    found: dict[str, tuple[pint.Unit, bool]] = {}
    for spelling in itertools.product(*choices):
        if any(map(_scaled_up_unscalable, spelling)):
            continue
        candidate = _respelled(text, spelling)
        unit = _pint_unit(candidate)
        if unit is not None and _dimensions(unit) in dimensions and (not unit.dimensionless or _plain(unit)):
            found.setdefault(candidate, (unit, any(map(_lowered_into_sub_milli, words, spelling))))
    distinct: dict[str, pint.Unit] = {}
    chosen: set[str] = set()  # readings that some casing gives without a sub-milli prefix from a capital
    for candidate, (unit, sub_milli) in found.items():
        same = next((c for c, other in distinct.items() if unit.dimensionality == other.dimensionality
                     and math.isclose(registry().Quantity(1.0, unit).to(other).magnitude, 1.0, rel_tol=1e-9)), None)
        if same is None:
            distinct[candidate] = unit
            same = candidate
        if not sub_milli:
            chosen.add(same)
    # A sub-milli reading still counts as a second reading ('PM': Pm or pm is refused, not read as petametres).
    if len(distinct) > 1:
        readings = " or ".join(f"{c} ({u})" for c, u in sorted(distinct.items()))
        raise AmbiguousUnit(f"unit {written!r} reads as {readings}: units are case-sensitive, write it in its own case")
    return next((distinct[c] for c in chosen), None)


def _plain(unit: pint.Unit) -> bool:
    """Whether a dimensionless unit is a ratio's (%, ‰) or an angle's (degree, radian): what a rig file writes, and
    not a word in capitals that pint also reads ('ALPHA' the fine-structure constant, 'MASS' milliarcseconds)."""
    return str(unit) in ("degree", "radian") or is_ratio_unit(Unit(format(unit, "~P"), unit))


def _marked_pressure(text: str) -> Unit | None:
    """A pressure unit marked absolute ('kPa(a)', 'bar abs': the pressure itself) or gauge ('kPa(g)': the project's
    gauge unit, e.g. kPag, which no factor converts to an absolute one); None when ``text`` carries no mark."""
    match = _PRESSURE_MARK.fullmatch(text)
    if match is None:
        match = _GLUED_MARK.fullmatch(text)
        glued = match and _pint_unit(match["unit"])
        if glued is None or _dimensions(glued) != _dimensions(registry().parse_units("Pa")):
            return None  # 'mA', 'kG': no pressure before the capital, so no mark
    name, mark = match["unit"], (match.groupdict().get("mark") or match["word"]).lower()
    pressure = _dimensions(registry().parse_units("Pa"))
    try:
        unit = parse_unit(name, frozenset({pressure})).unit
    except AmbiguousUnit:
        raise
    except UnitError:
        unit = None
    if unit is None or _dimensions(unit) != pressure:
        raise UnitError(f"unit {text!r}: '{name}' marked {'absolute' if mark.startswith('a') else 'gauge'} is no "
                        "pressure unit (write e.g. kPa(a), bar(g), psia)")
    if mark.startswith("a"):
        return Unit(format(unit, "~P"), unit)
    gauge = _GAUGE_OF.get(format(unit, "~P"))
    if gauge is None:
        raise UnitError(f"unit {text!r}: a gauge pressure is read in {', '.join(f'{u}(g)' for u in _GAUGE_OF)}; "
                        f"write the {name} values as absolute pressures or in one of those")
    return Unit(gauge, registry().parse_units(gauge))


# pint counts an angle in radians, so a bare frequency (Hz, 1/s, 1/min) is read as radians per time and 1 Hz as
# 9.55 rpm; a shaft speed written so counts revolutions (1 Hz = 60 rpm, '1/min' is rpm as German rigs write it).
_ANGLE_WORDS = ("radian", "revolution", "turn", "degree", "cycle", "grade", "arcminute", "arcsecond")


def revolutions_per_minute(unit: pint.Unit) -> float | None:
    """rpm per one ``unit`` of a shaft speed, or None when ``unit`` is no rotational speed; a unit naming no
    angle counts revolutions."""
    reg = registry()
    if unit.dimensionality != reg.parse_units("rpm").dimensionality:
        return None
    if any(word in str(unit) for word in _ANGLE_WORDS):
        return float(reg.Quantity(1.0, unit).to("rpm").magnitude)
    return float(reg.Quantity(1.0, unit).to("1/min").magnitude)


# Rig spellings of revolutions per minute that pint reads as something else or not at all: 'U/min' (Umdrehungen pro
# Minute, German rigs) is pint's enzyme unit per minute, 'u/min' atomic mass units per minute; 'r/min', 'rev/min'
# and 'min-1' it does not read. Read as another quantity, a speed setting's plausibility check was skipped.
_RPM_SPELLINGS = re.compile(r"(?:[ur1]|rev|upm)\s*/\s*min|min\s*(?:\^|\*\*)?\s*-\s*1|min⁻¹|u/?pm|r\.?p\.?m\.?",
                            re.IGNORECASE)


def parse_speed_unit(text: str) -> Unit:
    """The unit of a shaft speed: rig spellings of rpm (``U/min``, ``1/min``, ``min^-1``, ``r/min``, ``rev/min``)
    read as rpm, any other as :func:`parse_unit` reads it (raising :class:`UnitError`)."""
    if _RPM_SPELLINGS.fullmatch(text.strip().strip("[]()").strip()):
        return Unit("rpm", registry().parse_units("rpm"))
    return parse_unit(text)


def _dimensions(unit: pint.Unit) -> str:
    return "" if unit.dimensionless else str(unit.dimensionality)


def check_quantity(quantity: str, text: str | None) -> Unit | None:
    """The parsed unit of ``quantity`` (flow, pressure, efficiency), None when none is given; raises
    :class:`UnitError` when it is not understood or its dimensions do not fit the quantity."""
    if text is None:
        return None
    allowed = ALLOWED[quantity]
    if quantity == "pressure" and _MICRON.fullmatch(text.strip().strip("[]()").strip()):
        raise AmbiguousUnit(f"unit {text.strip()!r} of a pressure reads as a head in micrometres (µm) or as a vacuum "
                            "pressure in micrometres of mercury (µmHg, 0.133 Pa): write µm or µmHg")
    try:
        u = parse_unit(text, frozenset(allowed))
    except (AmbiguousUnit, StandardVolume):
        raise
    except UnitError:
        u = _weight_per_area(text) if quantity == "pressure" else None
        if u is None:
            raise
    if quantity == "pressure" and _dimensions(u.unit) not in allowed:
        u = _weight_per_area(text) or u  # 'kg/cm2': kgf/cm²; 'kg/cm2g' pint read as kilogram-grams per area
    if _dimensions(u.unit) not in allowed:
        raise UnitError(f"unit {text.strip()!r} ({u.unit.dimensionality if not u.dimensionless else 'dimensionless'})"
                        f" is not a unit of {quantity}: expected {' or '.join(allowed.values())}")
    if u.dimensionless and not is_ratio_unit(u):
        raise UnitError(f"unit {text.strip()!r} ({u.unit}) is no unit of a ratio or fraction: a dimensionless "
                        f"{quantity} is written '-', '1', '%' or '‰' (a symbol such as π or η names the quantity: "
                        "leave it out of the brackets)")
    if _holds_an_angle(u.unit):
        raise UnitError(f"unit {text.strip()!r} reads as {u.unit} (an angle in it: pint reads 'mass' as milli-arcseconds,"
                        f" 'rad' as radians), no unit of {quantity}: write it by its symbol (lbm/s, kg/s, lbf/in², %)")
    return u


def _holds_an_angle(unit: pint.Unit) -> bool:
    """Whether an angle is among the unit's factors. pint counts an angle dimensionless, so a word it splits into a
    prefix and an angle ('pounds mass' as pound·milli-arcsecond) passes for a mass flow off by a factor of 5e-9;
    no flow, pressure or efficiency of a rig table carries an angle."""
    return "radian" in str(registry().get_root_units(unit)[1])


_MASS_WORD = re.compile(r"\b(kg|g|t|lb|lbs|lbm)\b(?=\s*/)", re.IGNORECASE)
_PER_AREA = re.compile(r"(?P<unit>[^()]*/\s*(?:cm|m|in|ft|sq\s*in)\s*(?:2|²|\^2|\*\*2)?)\s*"
                       r"(?:\(\s*(?P<mark>a|abs|g|gauge)\s*\)|(?P<word>a|abs|g|gauge))?", re.IGNORECASE)


def _weight_per_area(text: str) -> Unit | None:
    """A mass per area under a pressure ('kg/cm2', 'KG/CM2 A', 'lb/in²') as the weight of that mass per area (kgf/cm²,
    lbf/in²): how data sheets write the technical atmosphere and psi; a mass per area is no pressure at all, so no
    other reading exists. None when ``text`` is no such unit; a gauge mark ('kg/cm2g') is refused, the project having
    no gauge unit of it."""
    match = _PER_AREA.fullmatch(text.strip().strip("[]").strip())
    if match is None or not _MASS_WORD.search(match["unit"]):
        return None
    force = _MASS_WORD.sub(lambda m: {"lbs": "lbf", "lbm": "lbf"}.get(m[1].lower(), m[1].lower() + "f"),
                           match["unit"].lower().replace("sq in", "in**2").replace("sqin", "in**2"))
    try:
        unit = parse_unit(force)
    except UnitError:
        return None
    if _dimensions(unit.unit) != _dimensions(registry().parse_units("Pa")):
        return None
    if (match["mark"] or match["word"] or "a").lower().startswith("g"):
        raise UnitError(f"unit {text.strip()!r} is a gauge pressure in {unit.text}, which is read only in "
                        f"{', '.join(f'{u}(g)' for u in _GAUGE_OF)}: convert it (1 kgf/cm² = 0.980665 bar) or give "
                        "absolute pressures")
    return unit


def is_ratio_unit(u: Unit) -> bool:
    """Whether a dimensionless unit scales a ratio by a power of ten (1, %, ‰, ppm, kg/kg): pint also reads π as a
    number (3.14...), dB and Np as logarithmic ratios, and angles, bits and counts as dimensionless."""
    q = registry().Quantity(1.0, u.unit).to_root_units()
    if not q.dimensionless or str(q.units) != "dimensionless" or not q.magnitude > 0:
        return False
    return abs(math.log10(q.magnitude) - round(math.log10(q.magnitude))) < 1e-9


def is_gauge(unit: Unit | None) -> bool:
    return unit is not None and str(unit.unit) in GAUGE


def speed_unit_error(name: str, text: str | None) -> str | None:
    """Why ``text`` cannot be the unit of the speed setting ``name`` (a temperature, a mass …), or None; a label
    pint cannot read stays a label (settings' units are labels)."""
    if not text:
        return None
    try:
        u = parse_speed_unit(text)
    except UnitError:
        return None
    reg = registry()
    if not any(u.unit.dimensionality == reg.parse_units(other).dimensionality for other in OTHER_QUANTITIES):
        return None
    return (f"setting {name!r} is named as a speed but its unit {text.strip()!r} is {_dimensions(u.unit)}: expected "
            "a speed, "
            f"{' or '.join(SPEED_DIMENSIONS.values())} — another column (a temperature?) read as the speed? Map the "
            "columns with the 'columns' option, or state the speed's own unit")


def fraction_factor(text: str | None) -> float:
    """Factor from an efficiency unit to a fraction (0.01 for '%'); 1 without a unit."""
    u = check_quantity("efficiency", text)
    return 1.0 if u is None else float(registry().Quantity(1.0, u.unit).to("dimensionless").magnitude)


def conversion(quantity: str, given: str | None, wanted: str | None) -> tuple[float, str | None]:
    """(factor, unit): multiply values in ``given`` by factor to get them in ``wanted`` (the unit then stated);
    without ``wanted`` the values stay in ``given``. Raises :class:`UnitError` (the message says which side)."""
    src = check_quantity(quantity, given)
    if wanted is None:
        return 1.0, None if src is None else src.text
    dst = check_quantity(quantity, wanted)
    if src is None:
        raise UnitError(f"result unit {wanted!r} asked for but the {quantity} has no unit: state it in "
                        f"units.{quantity} (or in the column header, e.g. '{quantity} [{wanted}]')")
    try:
        return src.factor_to(dst), dst.text
    except pint.errors.DimensionalityError:
        raise UnitError(f"{quantity} in {given!r} cannot be converted to {wanted!r} (other dimensions)") from None


def _ratio_of(quantity: str, src: Unit | None) -> Unit | None:
    """A pressure ratio stated in per cent or per mille, as the plain ratio it is (like an efficiency in %): the
    plausibility range, the plots and the cycle codes' PR tables are ratios (155 % is PR 1.55, not 155)."""
    if quantity == "pressure" and src is not None and src.dimensionless and src.text != "1":
        return check_quantity("pressure", "1")
    return None


def to_internal(request: PerfmapRequest) -> tuple[PerfmapRequest, ResultUnits]:
    """The request in the solver's internal units (module docstring) and the units it is then in; raises
    :class:`InputRejected` naming ``units.<quantity>`` or ``options.result_units.<quantity>``."""
    given = request.units or QuantityUnits()
    wanted = request.options.result_units or ResultUnitsOption()
    errors: list[FieldError] = []
    factors: dict[str, float] = {}
    stated: dict[str, str | None] = {}
    for quantity in ("flow", "pressure"):
        src_text, dst_text = getattr(given, quantity), getattr(wanted, quantity)
        try:
            src = check_quantity(quantity, src_text)
        except UnitError as e:
            errors.append(FieldError(("units", quantity), str(e)))
            continue
        try:
            dst = check_quantity(quantity, dst_text)
        except UnitError as e:
            errors.append(FieldError(("options", "result_units", quantity), str(e)))
            continue
        dst = dst if dst is not None else _ratio_of(quantity, src)
        if dst is not None and src is not None and is_gauge(src) != is_gauge(dst):
            errors.append(FieldError(("options", "result_units", quantity),
                                     f"{quantity} in {src.text!r} cannot be converted to {dst.text!r}: one is a gauge "
                                     "pressure (above the ambient) and the other absolute, and the ambient pressure "
                                     "is not known; ask for a unit of the same kind (barg, psig, mbarg for gauge)"))
            continue
        if dst is None or (src is not None and src.unit == dst.unit):
            factors[quantity], stated[quantity] = 1.0, None if src is None else src.text
        elif src is None:
            errors.append(FieldError(("options", "result_units", quantity),
                                     f"{quantity} in {dst_text!r} asked for, but the request does not state the unit "
                                     f"its {quantity} is in: give units.{quantity} (or a unit in the column header, "
                                     f"e.g. '{quantity} [{dst_text}]')"))
        else:
            try:
                factors[quantity], stated[quantity] = src.factor_to(dst), dst.text
            except pint.errors.DimensionalityError:
                errors.append(FieldError(("options", "result_units", quantity),
                                         f"{quantity} in {src.text!r} cannot be converted to {dst_text!r} "
                                         "(other dimensions)"))
    try:
        factors["efficiency"] = fraction_factor(given.efficiency)
    except UnitError as e:
        errors.append(FieldError(("units", "efficiency"), str(e)))
    if errors:
        raise InputRejected(errors)
    d = len(request.setting_names)
    settings = [u or None for u in (request.setting_units or [None] * d)]
    units = ResultUnits(flow=stated["flow"], pressure=stated["pressure"], settings=settings)
    if all(f == 1.0 for f in factors.values()):
        return request, units
    positions = [p.model_copy(update={q: [v * factors[q] for v in getattr(p, q)] for q in MEASURED})
                 for p in request.positions]
    converted = request.model_copy(update={
        "positions": positions,
        "units": QuantityUnits(flow=units.flow, pressure=units.pressure, efficiency="1")})
    return converted, units


def request_conversions(request: PerfmapRequest) -> list[dict]:
    """The conversions :func:`to_internal` makes, as ``report.details.source`` states them (called on a request
    that passed it): the efficiency unit to a fraction, flow and pressure to ``options.result_units``."""
    given = request.units or QuantityUnits()
    wanted = request.options.result_units or ResultUnitsOption()
    out = []
    factor = fraction_factor(given.efficiency)
    if factor != 1.0:
        out.append({"quantity": "efficiency", "column": None, "from_unit": given.efficiency, "to_unit": "1",
                    "factor": factor, "basis": "request"})
    for quantity in ("flow", "pressure"):
        src, dst = check_quantity(quantity, getattr(given, quantity)), check_quantity(quantity, getattr(wanted, quantity))
        basis = "result_units" if dst is not None else "ratio"
        dst = dst if dst is not None else _ratio_of(quantity, src)
        if src is not None and dst is not None and src.unit != dst.unit:
            out.append({"quantity": quantity, "column": None, "from_unit": src.text, "to_unit": dst.text,
                        "factor": src.factor_to(dst), "basis": basis})
    return out
