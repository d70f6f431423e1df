"""Pressure units as instruments and process data sheets write them (trust51r probe), each refused before:

- upper case where re-casing gave two readings of which one is no unit anyone uses: 'MMHG' (mmHg or megametres of
  mercury, 1.3 million bar), 'MTORR' (mTorr or megatorr), 'MMWC', 'MBARG'. Read as the one in use; 'MBAR' and 'MPA'
  stay refused, megabar and millipascal being units in use;
- an absolute or gauge mark after a space or glued as a capital: 'bar g', 'kPa a', 'psi G', 'MPaA' (pint read
  'bar g' as bar times grams, a refusal naming mass squared);
- a mass per area, the technical atmosphere as data sheets write it: 'kg/cm2', 'KG/CM2A', 'lb/in2' (kgf/cm²,
  lbf/in²); its gauge form 'kg/cm2g' is refused saying it is a gauge pressure, the project having no gauge unit of it.
Each read value is checked against pint's own factor to kPa."""

from __future__ import annotations

import pint
import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.perfmap.upload import parse_upload
from plantsolve.solvers.perfmap.validation import load
from tests.solvers.perfmap.conftest import DATA

N3 = (DATA / "n3_fan_map.csv").read_text()
HEADER = "theta,phi,flow,pressure,efficiency"
PINT = pint.UnitRegistry()


def _load(header: str, options=None):
    source = StoredInput.from_bytes("rig.csv", N3.replace(HEADER, header, 1).encode())
    return load(parse_upload(source, {"map": False, **(options or {})}), source)


def _to_kpa(pint_text: str) -> float:
    return PINT.Quantity(1.0, pint_text).to("kilopascal").magnitude


@pytest.mark.parametrize("written, pint_text", [
    ("MMHG", "millimeter_Hg"), ("mmHG", "millimeter_Hg"), ("MTORR", "millitorr"), ("MMH2O", "millimeter_H2O"),
    ("MMWC", "millimeter_H2O"), ("bar a", "bar"), ("BAR A", "bar"), ("kPa a", "kilopascal"), ("MPaA", "megapascal"),
    ("kPaA", "kilopascal"), ("kg/cm2", "kilogram_force / centimeter ** 2"), ("KG/CM2A", "kilogram_force / centimeter ** 2"),
    ("kg/cm²", "kilogram_force / centimeter ** 2"), ("lb/in2", "pound_force / inch ** 2"),
])
def test_a_pressure_unit_in_use_is_read_at_pints_factor(written, pint_text):
    loaded = _load(f"theta,phi,flow,pressure [{written}],efficiency", {"result_units": {"pressure": "kPa"}})
    factors = [c["factor"] for c in loaded.source["conversions"] if c["quantity"] == "pressure"] or [1.0]  # kPa: none
    assert factors == [pytest.approx(_to_kpa(pint_text), rel=1e-12)]
    assert loaded.internal.positions[0].pressure[0] == pytest.approx(1.076 * _to_kpa(pint_text), rel=1e-12)


def test_a_data_sheets_unit_after_a_comma_is_read_too():
    loaded = _load('theta,phi,flow,"Pressure, kg/cm2 A",efficiency', {"result_units": {"pressure": "bar"}})
    assert loaded.internal.positions[0].pressure[0] == pytest.approx(1.076 * 0.980665, rel=1e-12)


@pytest.mark.parametrize("written, gauge", [("bar g", "barg"), ("psi G", "psig"), ("kPa g", "kPag"), ("MBARG", "mbarg"),
                                            ("barG", "barg")])
def test_a_spaced_or_glued_gauge_mark_is_the_gauge_unit(written, gauge):
    loaded = _load(f"theta,phi,flow,pressure [{written}],efficiency")
    assert loaded.units.pressure == gauge
    with pytest.raises(InputRejected) as refused:  # and, gauge, it is not converted to an absolute unit
        _load(f"theta,phi,flow,pressure [{written}],efficiency", {"result_units": {"pressure": "kPa"}})
    assert refused.value.errors[0].loc == ("options", "result_units", "pressure")


@pytest.mark.parametrize("written", ["kg/cm2g", "kg/cm2(g)", "kg/cm²G"])
def test_a_gauge_mass_per_area_is_refused_saying_it_is_gauge(written):
    with pytest.raises(InputRejected) as refused:
        _load(f"theta,phi,flow,pressure [{written}],efficiency")
    (error,) = refused.value.errors
    assert error.loc == ("file", "header") and "gauge pressure in kgf/cm²" in error.msg


@pytest.mark.parametrize("written, readings", [("MBAR", ("Mbar", "mbar")), ("MPA", ("MPa", "mPa"))])
def test_two_readings_in_use_are_still_refused_naming_both(written, readings):
    with pytest.raises(InputRejected) as refused:
        _load(f"theta,phi,flow,pressure [{written}],efficiency")
    (error,) = refused.value.errors
    assert error.loc == ("file", "header") and all(r in error.msg for r in readings)


@pytest.mark.parametrize("written", ["MINHG", "kg/cm"])
def test_no_reading_is_made_up(written):
    with pytest.raises(InputRejected) as refused:  # 'MINHG' is no milli-inch of mercury; a mass per length no pressure
        _load(f"theta,phi,flow,pressure [{written}],efficiency")
    assert refused.value.errors[0].loc == ("file", "header")


def test_a_mass_per_area_under_a_flow_is_still_refused():
    with pytest.raises(InputRejected) as refused:
        _load("theta,phi,flow [kg/cm2],pressure,efficiency")
    assert "not a unit of flow" in refused.value.errors[0].msg
