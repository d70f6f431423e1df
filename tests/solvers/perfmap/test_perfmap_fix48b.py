"""Findings of review 48 on perfmap units and uploads: normal litres ('Nl/min', 'NL/MIN') re-cased into nanolitres
(flows a million times too small, no warning), a leading capital re-cased into a prefix below milli, 'MICRON' under a
pressure read as a head in micrometres (vacuum gauges mean µmHg), a gauge mark after the unit's brackets refused as
'missing: pressure' without naming the column, and the speed-line message naming compressors only."""

from __future__ import annotations

import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.perfmap.units import AmbiguousUnit, UnitError, check_quantity
from plantsolve.solvers.perfmap.upload import parse_upload
from plantsolve.solvers.perfmap.validation import load
from tests.solvers.perfmap.conftest import DATA

N3 = (DATA / "n3_fan_map.csv").read_text()
HEADER = "theta,phi,flow,pressure,efficiency"


def _load(header: str, options=None):
    source = StoredInput.from_bytes("rig.csv", N3.replace(HEADER, header, 1).encode())
    return load(parse_upload(source, {"map": False, **(options or {})}), source)


@pytest.mark.parametrize("unit", ["Nl/min", "NL/MIN", "Nl/h", "NL/S", "Sl/min", "Nml/min", "Ncm3/min", "SLPM", "slm",
                                  "sccm", "Nm3/day", "kNm3/h", "scf/min", "KSCFM"])
def test_normal_and_standard_litres_are_refused_as_standard_volumes(unit):
    """'NL/MIN' read as nanolitres per minute: with result_units m3/h the flows came out 6e-11 of the rig's, stated
    as 'nl/min' and no warning. A standard volume is a mass flow in disguise; no factor makes it an actual one."""
    with pytest.raises(InputRejected) as refused:
        _load(f"theta,phi,flow [{unit}],pressure,efficiency", options={"result_units": {"flow": "m3/h"}})
    (error,) = refused.value.errors
    assert error.loc == ("file", "header") and f"flow [{unit}]" in error.msg
    assert "standard (normal) conditions" in error.msg


@pytest.mark.parametrize("quantity, unit", [("pressure", "NM"), ("pressure", "NPA"), ("flow", "NG/S"),
                                            ("flow", "FL/MIN")])
def test_a_leading_capital_is_never_recased_into_a_prefix_below_milli(quantity, unit):
    """Each read before as nano- or femto-units (a head of nanometres, nanopascals): values off by 1e6 to 1e15,
    confidently. A capital U is upper case's µ, and read so ('UMHG' is µmHg: tests/solvers/perfmap/
    test_trust49_units.py)."""
    with pytest.raises(UnitError):
        check_quantity(quantity, unit)


@pytest.mark.parametrize("unit, readings", [("PM", ("Pm", "pm")), ("PL/S", ("PL/s", "pL/s")),
                                            ("PG/S", ("Pg/s", "pg/s"))])
def test_a_sub_milli_reading_still_makes_a_casing_ambiguous(unit, readings):
    """Not read as peta-units for want of the pico reading: refused naming both, as before."""
    quantity = "pressure" if unit == "PM" else "flow"
    with pytest.raises(AmbiguousUnit) as refused:
        check_quantity(quantity, unit)
    assert all(r in str(refused.value) for r in readings)


@pytest.mark.parametrize("unit, stated, pa", [("FT", "ft", None), ("PSI", "psi", 6894.757293168361),
                                              ("MH2O", "mH2O", 9806.65), ("KPA", "kPa", 1000.0)])
def test_capitals_that_are_no_sub_milli_prefix_are_still_read(unit, stated, pa):
    u = check_quantity("pressure", unit)
    assert u.text == stated
    if pa is not None:
        assert u.factor_to(check_quantity("pressure", "Pa")) == pytest.approx(pa, rel=1e-9)


@pytest.mark.parametrize("unit", ["MICRON", "micron", "Microns"])
def test_micron_under_a_pressure_is_refused_as_a_head_or_a_vacuum_pressure(unit):
    """'MICRON' read as a head in micrometres; on vacuum rigs it is µmHg (0.133 Pa), 13.6 times a micrometre of
    water head, and a head in µm is no rig's unit."""
    with pytest.raises(InputRejected) as refused:
        _load(f"theta,phi,flow,pressure [{unit}],efficiency")
    (error,) = refused.value.errors
    assert error.loc == ("file", "header") and "µmHg" in error.msg and "micrometres" in error.msg
    assert check_quantity("pressure", "umHg").factor_to(check_quantity("pressure", "Pa")) == pytest.approx(
        0.133322387415, rel=1e-6)


@pytest.mark.parametrize("header, says, suggested, reads", [
    ("pressure [kPa] (g)", "gauge mark outside the unit: write", "pressure [kPa(g)]", "kPag"),
    ("Pressure (psi) (gauge)", "gauge mark outside the unit: write", "Pressure [psi(gauge)]", "psig"),
    ("pressure [bar] (a)", "absolute mark outside the unit: write", "pressure [bar(a)]", "bar"),
    ("pressure (g)", "gauge mark without a unit: write the unit with its mark, e.g.", "pressure [kPa(g)]", "kPag"),
])
def test_a_pressure_mark_after_the_units_brackets_is_refused_naming_the_column(header, says, suggested, reads):
    """Refused as 'missing: pressure', the column not named: the mark belongs inside the unit's brackets; the header
    the message suggests reads."""
    with pytest.raises(InputRejected) as refused:
        _load(f"theta,phi,flow,{header},efficiency")
    (error,) = refused.value.errors
    assert error.loc == ("file", "header")
    assert error.msg == f"column {header!r} (line 1, column 4): {says} {suggested}"
    assert _load(f"theta,phi,flow,{suggested},efficiency").units.pressure == reads


def test_a_speed_at_zero_is_warned_without_naming_compressors():
    """perfmap reads fans' and pumps' maps too: their speed lines also run at positive speeds."""
    rows = [f"{s:g},{f + 0.5 * k:g},{base - 0.02 * k * k:g},{0.8 + 0.02 * k - 0.01 * k * k:g}"
            for s, base in zip((0.0, 0.9, 1.0), (1.0, 1.2, 1.4)) for k, f in enumerate((10, 11, 12, 13))]
    source = StoredInput.from_bytes("rig.csv", "\n".join(["speed,flow [kg/s],PR,efficiency", *rows]).encode())
    (warning,) = [w for w in load(parse_upload(source, {"map": False}), source).warnings
                  if w.code == "implausible_speed"]
    assert "zero: speed lines run at positive speeds" in warning.message and "compressor" not in warning.message
