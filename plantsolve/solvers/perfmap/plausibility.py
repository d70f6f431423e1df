"""Plausibility of a rig table's values for a compressor: warnings ``implausible_<quantity>`` naming the
quantity, the values, the plausible range and the likely mix-up (the README's perfmap section lists them).

The values are those the solver uses (efficiency a fraction, flow and pressure in the result's units). A range
is checked only where the unit says what the numbers mean: a flow or pressure stated in no unit may be anything.
"""

from __future__ import annotations

import re

import numpy as np

from plantsolve.schemas.common import Diagnostic
from plantsolve.schemas.perfmap import PerfmapRequest, ResultUnits
from plantsolve.solvers.perfmap.gasturb_map import MAX_RELATIVE_SPEED
from plantsolve.solvers.perfmap.setting_lines import Setting
from plantsolve.solvers.perfmap.speed_names import named_as_speed
from plantsolve.solvers.perfmap.units import UnitError, parse_speed_unit, parse_unit, registry, revolutions_per_minute

# peak isentropic/polytropic efficiency of a compressor's speed line
EFFICIENCY_PEAK = (0.2, 0.98)
# total pressure ratio of one compressor (fans from 1.02, centrifugal stages to about 12, whole cores to 60)
PRESSURE_RATIO = (1.0, 60.0)
# pressures (a rise or an absolute level) in Pa: a low-pressure fan's 100 Pa to 500 bar
PRESSURE_PA = (10.0, 5e7)
# mass flows in kg/s (a test rig's turbocharger to the largest fan) and volume flows in m³/s
MASS_FLOW_KG_S = (1e-4, 1e4)
VOLUME_FLOW_M3_S = (1e-6, 1e4)
# the largest flow of a map in per cent of its design flow (the top speed line's choke end): a partial map of low
# speed lines still reaches a few per cent, overspeed lines some 120 %
FLOW_PERCENT = (5.0, 200.0)
# corrected speeds: as a fraction of design, in per cent, and in rpm
SPEED_FRACTION = (0.05, 1.5)
SPEED_PERCENT = (5.0, 150.0)
SPEED_RPM = (100.0, 250_000.0)


def _range(values: np.ndarray) -> str:
    return f"{values.min():.4g}..{values.max():.4g}"


def _warning(code: str, message: str, **details) -> Diagnostic:
    return Diagnostic(code=code, message=message, details=details)


def _efficiency(settings: list[Setting]) -> list[Diagnostic]:
    peaks = np.array([s.eta.max() for s in settings])
    lo, hi = EFFICIENCY_PEAK
    low = [s.label for s, p in zip(settings, peaks) if p < lo]
    high = [s.label for s, p in zip(settings, peaks) if p > hi]
    out = []
    if low:
        out.append(_warning(
            "implausible_efficiency",
            f"Efficiency: the peak of {len(low)} of {len(settings)} speed line(s) is below {lo:g} (peaks "
            f"{_range(peaks)}; a compressor's peak isentropic efficiency lies in {lo:g}..{hi:g}): a fraction divided "
            "by 100 again (a '%' header over values already fractions), or another column read as efficiency?",
            quantity="efficiency", range=list(EFFICIENCY_PEAK), peaks=[float(p) for p in peaks[:100]],
            settings=low[:100]))
    if high:
        out.append(_warning(
            "implausible_efficiency",
            f"Efficiency: the peak of {len(high)} speed line(s) is above {hi:g} (up to {peaks.max():.4g}); no "
            f"compressor reaches that: a polytropic or another efficiency, or values rounded up?",
            quantity="efficiency", range=list(EFFICIENCY_PEAK), peaks=[float(p) for p in peaks[:100]],
            settings=high[:100]))
    return out


def _pressure(settings: list[Setting], unit: str | None) -> list[Diagnostic]:
    if unit is None:
        return []
    values = np.concatenate([s.y for s in settings])
    if unit in ("1", "-"):
        lo, hi = PRESSURE_RATIO
        # low speed lines of a real map run below 1 towards choke (GasTurb's own maps do); an inverse ratio or a
        # pressure rise puts most of the map there
        low = float(np.median(values)) < lo
        if low or values.max() > hi:
            return [_warning(
                "implausible_pressure_ratio",
                f"Pressure ratio: values {_range(values)} lie outside {lo:g}..{hi:g}, the range of a compressor's "
                "total pressure ratio: " + ("an inverse ratio p1/p2, or a pressure rise read as a ratio?"
                                            if low else "a pressure (kPa, psi) read as a ratio?"),
                quantity="pressure", unit="1", range=[lo, hi], values=[float(values.min()), float(values.max())])]
        return []
    try:
        parsed = parse_unit(unit)
        pa = values * float(registry().Quantity(1.0, parsed.unit).to("Pa").magnitude)
    except (UnitError, Exception):  # a head or a specific work: no pressure range applies
        return []
    lo, hi = PRESSURE_PA
    if pa.min() < lo or pa.max() > hi:
        return [_warning(
            "implausible_pressure",
            f"Pressure: values {_range(values)} {unit} ({_range(pa)} Pa) lie outside {lo:g}..{hi:g} Pa: "
            + ("Pa read as bar or kPa?" if pa.max() > hi else "a ratio or bar read as Pa?"),
            quantity="pressure", unit=unit, range_pa=[lo, hi], values=[float(values.min()), float(values.max())])]
    return []


def _flow_sign(settings: list[Setting]) -> list[Diagnostic]:
    """Flows of both signs: a compressor's characteristic runs at one sign of flow in any unit, so the few of the
    other sign are a lost or stray minus."""
    values = np.concatenate([s.x for s in settings])
    negative = values < 0
    if negative.all():
        # a rig that counts flow against its axis: mirrored, every line's pressure rises with flow and no
        # decreasing concave curve fits it; the fit warnings alone would not say why
        return [_warning(
            "implausible_flow",
            f"Flow: every flow is negative ({_range(values)}); a compressor's flow is positive: a sign convention "
            "of the rig (flow counted against the axis)? The speed lines are fitted as given, mirrored: their "
            "pressure rises with flow. Give the flows without the minus.",
            quantity="flow", values=[float(values.min()), float(values.max())], settings=[])]
    if not negative.any():
        return []
    stray_negative = negative.sum() <= (~negative).sum()
    where = [(s.label, float(x)) for s in settings for x in s.x if (x < 0) == stray_negative]
    return [_warning(
        "implausible_flow",
        f"Flow: {len(where)} of {values.size} flows have the other sign than the rest ("
        + ", ".join(f"{v:g} at {label}" for label, v in where[:5]) + (" …" if len(where) > 5 else "")
        + "): a lost or stray minus? The speed lines through them are fitted as given.",
        quantity="flow", values=[v for _, v in where[:100]], settings=[label for label, _ in where[:100]])]


def _flow(settings: list[Setting], unit: str | None) -> list[Diagnostic]:
    if unit is None or unit in ("1", "-"):
        return []
    values = np.concatenate([s.x for s in settings])
    if unit.strip().strip("[]()").strip() == "%":
        return _flow_percent(values, unit)
    try:
        q = registry().Quantity(1.0, parse_unit(unit).unit)
    except UnitError:
        return []
    for target, (lo, hi), words in (("kg/s", MASS_FLOW_KG_S, "mass flow"), ("m**3/s", VOLUME_FLOW_M3_S, "volume flow")):
        if q.check(registry().parse_units(target).dimensionality):
            si = np.abs(values) * float(q.to(target).magnitude)  # a sign is _flow_sign's
            if si.min() < lo or si.max() > hi:
                return [_warning(
                    "implausible_flow",
                    f"Flow: {words} {_range(values)} {unit} ({_range(si)} {target.replace('**', '^')}) lies outside "
                    f"{lo:g}..{hi:g} {target.replace('**', '^')}, the range of compressors: "
                    + ("g/s or lbm/min read as kg/s, or m3/h as m3/s?" if si.max() > hi
                       else "kg/h read as kg/s, or a relative flow with a unit?"),
                    quantity="flow", unit=unit, range=[lo, hi], values=[float(values.min()), float(values.max())])]
            return []
    return []


def _flow_percent(values: np.ndarray, unit: str) -> list[Diagnostic]:
    """A flow in per cent of design: its largest value is the top speed line's choke flow, not thousands of per cent
    (kg/s or lbm/s labelled %) nor below a few per cent (fractions labelled %)."""
    top = float(np.abs(values).max())
    lo, hi = FLOW_PERCENT
    if lo <= top <= hi:
        return []
    return [_warning(
        "implausible_flow",
        f"Flow: values {_range(values)} {unit}; the largest flow of a map in per cent of design lies in {lo:g}..{hi:g} "
        + ("%: a mass or volume flow (kg/s, lbm/s) labelled %?" if top > hi else "%: fractions of design labelled %?"),
        quantity="flow", unit=unit, range=[lo, hi], values=[float(values.min()), float(values.max())])]


# Names rigs give a vane setting, matched as named_as_speed matches: such a setting is never the speed the cycle-code
# exports take the last setting for. Not theta and phi: the paper's vane angles, but this project's pyCycle example
# (and its readers' users) put the speed in phi; their unit tells (an angle is no speed)
GEOMETRY_NAMES = {"igv", "igv angle", "inlet guide vane", "inlet guide vanes", "vgv", "vgv angle",
                  "variable guide vane", "stator angle", "vsv", "alpha", "α", "alphamap", "alpha map", "diffuser",
                  "diffuser angle", "diffuser vane", "diffuser setting"}


def _is_angle(unit: str | None) -> bool:
    try:
        return unit is not None and any(w in str(parse_unit(unit).unit) for w in ("degree", "radian"))
    except UnitError:
        return False


def last_setting_not_speed(names: list[str], units: list[str | None]) -> Diagnostic | None:
    """The warning of exports whose speed lines are no speed: map_pycycle.py's NcMap, the GasTurb tables' speed
    column and the (speed, beta) query take the LAST setting for the speed; a last setting named or measured as a
    vane angle (the paper's diffuser angle phi in degrees; a table whose diffuser column follows its speed) is
    written there as the speed, and a cycle code runs it so."""
    last, unit = names[-1], units[-1] if units else None
    speed = [n for n in names[:-1] if named_as_speed(n)]
    plain = re.sub(r"[\s_\-]+", " ", re.sub(r"\s*[\[(].*$", "", last).strip().lower())
    if named_as_speed(last) or not (speed or plain in GEOMETRY_NAMES or _is_angle(unit)):
        return None
    because = f"the speed is {speed[0]!r}" if speed else f"{last!r} is a vane setting" + (
        f" (in {unit})" if _is_angle(unit) else "")
    return _warning(
        "exports_last_setting_not_speed",
        f"The cycle-code exports (map_pycycle.py's NcMap, map_gasturb*.map's speed lines) and the (speed, beta) "
        f"query take the last setting, {last!r}, for the speed, but {because}: a cycle code would run its values as "
        "corrected speeds. List the speed last in setting_names (and each position's setting values in that order) "
        "for exports a cycle code can use.", quantity="settings", setting=last, setting_names=list(names))


def exports_speed_not_relative(names: list[str], units: list[str | None], speeds: list[float]) -> Diagnostic | None:
    """The warning of a GasTurb export whose speed column is no relative speed: the tables hold the last setting's
    values as fitted, and GasTurb and GSP read a map's speed as relative corrected speed, so a map in rpm or per
    cent reads there as a speed 100 or 10,000 times its design (pyCycle scales NcMap by its design point: its
    export works in any speed unit)."""
    unit = units[-1] if units else None
    values = np.asarray(speeds, dtype=float)
    try:
        parsed = parse_speed_unit(unit) if unit else None
    except UnitError:
        return None
    if parsed is not None and parsed.dimensionless and parsed.text == "1":
        return None
    if parsed is None and (values.max() <= MAX_RELATIVE_SPEED or not named_as_speed(names[-1])):
        return None  # a unitless setting not named as the speed (the paper's phi) is not judged, as above
    if parsed is not None and not parsed.dimensionless and revolutions_per_minute(parsed.unit) is None:
        return None  # not a rotational speed (an angle is exports_last_setting_not_speed's)
    written = f"{_range(values)} {unit}" if unit else f"{_range(values)} (no unit stated)"
    return _warning(
        "exports_speed_not_relative",
        f"The GasTurb export (map_gasturb*.map) writes the speed lines' values as fitted, {names[-1]!r} {written}, in "
        f"its speed column, which GasTurb and GSP read as relative corrected speed (N/sqrt(theta) over its design "
        f"value, about 0.2 to 1.1; a .map read here warns implausible_speed above {MAX_RELATIVE_SPEED:g}). Submit the "
        "speed as a fraction of design (a column 'Nc [-]') for a GasTurb map, or set the cycle code's map design "
        "speed in these units. map_pycycle.py is scaled by pyCycle's design point and works in any speed unit.",
        quantity="settings", setting=names[-1], unit=unit, values=[float(values.min()), float(values.max())])


def _speed(request: PerfmapRequest, units: ResultUnits, settings: list[Setting]) -> list[Diagnostic]:
    out = []
    for k, name in enumerate(request.setting_names):
        if not named_as_speed(name):
            continue
        values = np.array([s.values[k] for s in settings], dtype=float)
        unit = units.settings[k] if k < len(units.settings) else None
        if values.min() <= 0:  # in any unit or none: no speed line runs at zero or backwards
            out.append(_warning(
                "implausible_speed",
                f"Corrected speed {name!r}: values {_range(values)} include "
                f"{'negative speeds' if values.min() < 0 else 'zero'}: speed lines run at positive "
                "speeds: a stray minus, or another column (an angle?) read as the speed?",
                quantity=name, unit=unit, range=[0.0, None], values=[float(values.min()), float(values.max())]))
            continue
        try:
            parsed = parse_speed_unit(unit) if unit else None
        except UnitError:
            continue
        if parsed is None:
            continue
        if parsed.dimensionless and parsed.text in ("1", "%"):
            lo, hi = SPEED_PERCENT if parsed.text == "%" else SPEED_FRACTION
            mixup = ("fractions of design speed labelled %?" if parsed.text == "%" and values.max() <= SPEED_FRACTION[1]
                     else "per cent or rpm labelled as a fraction?")
        else:
            rpm = revolutions_per_minute(parsed.unit)
            if rpm is None:  # not a rotational speed: a label pint reads as something else
                continue
            values = values * rpm
            lo, hi = SPEED_RPM
            mixup = "a relative speed (fraction or %) labelled rpm?"
        if values.min() < lo or values.max() > hi:
            out.append(_warning(
                "implausible_speed",
                f"Corrected speed {name!r}: values {_range(values)} {unit if parsed.text != 'rpm' else 'rpm'} lie outside "
                f"{lo:g}..{hi:g}: {mixup}",
                quantity=name, unit=unit, range=[lo, hi], values=[float(values.min()), float(values.max())]))
    return out


def plausibility_warnings(request: PerfmapRequest, units: ResultUnits, settings: list[Setting]) -> list[Diagnostic]:
    """Every ``implausible_*`` warning of a prepared request (in the solver's units)."""
    return (_efficiency(settings) + _pressure(settings, units.pressure) + _flow(settings, units.flow)
            + _flow_sign(settings) + _speed(request, units, settings))
