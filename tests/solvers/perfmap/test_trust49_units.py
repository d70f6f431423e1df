"""Units of the trust49 probe: volumes at normal or standard conditions written in lower case ('nl/min', 'nm3/h') after
a comma or in the cells were refused without a reason ('the header must name the columns', 'not a number'); vacuum
and fan rigs' pressure units ('UMHG', 'mTorr', 'inWC') were refused as not understood or as megatorr-or-millitorr.
Each is read at pint's own factor, or refused naming the column and why, as its upper- and lower-case spellings are."""

from __future__ import annotations

import pint
import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.perfmap.upload import parse_upload
from plantsolve.solvers.perfmap.validation import load
from tests.solvers.perfmap.conftest import DATA

N3 = (DATA / "n3_fan_map.csv").read_text()
HEADER = "theta,phi,flow,pressure,efficiency"


def _load(text: str, options=None):
    source = StoredInput.from_bytes("rig.csv", text.encode())
    return load(parse_upload(source, {"map": False, **(options or {})}), source)


def _with_header(header: str) -> str:
    return N3.replace(HEADER, header, 1)


def _with_cell_unit(column: int, unit: str) -> str:
    lines = N3.splitlines()
    rows = [line.split(",") for line in lines[1:]]
    for row in rows:
        row[column] = f"{row[column]} {unit}"
    return "\n".join([lines[0], *(",".join(row) for row in rows)]) + "\n"


STANDARD_VOLUMES = ("nl/min", "nm3/h", "Nl/min", "Nm3/h", "NM3/H", "scfm")


@pytest.mark.parametrize("unit", STANDARD_VOLUMES)
@pytest.mark.parametrize("where", ["brackets", "comma", "cells"])
def test_a_flow_at_normal_conditions_is_refused_naming_the_column_the_unit_and_why(unit, where):
    """Before: after a comma the header was 'must name the columns flow, …' and in the cells every row 'is not a
    number', saying neither the unit nor why; in brackets it was already refused so."""
    text = {"brackets": lambda: _with_header(f"theta,phi,flow [{unit}],pressure,efficiency"),
            "comma": lambda: _with_header(f'theta,phi,"flow, {unit}",pressure,efficiency'),
            "cells": lambda: _with_cell_unit(2, unit)}[where]()
    with pytest.raises(InputRejected) as refused:
        _load(text)
    (error,) = refused.value.errors
    assert error.loc == ("file", "header") and "column 'flow" in error.msg and "column 3" in error.msg
    assert f"unit {unit!r}" in error.msg and "standard (normal) conditions" in error.msg
    assert "kg/s" in error.msg  # what to write instead


# (as written, pint's own name of the unit): the factor to kPa must be pint's, whatever the casing
PRESSURES = [("umHg", "micrometer_Hg"), ("µmHg", "micrometer_Hg"), ("UMHG", "micrometer_Hg"),
             ("mmHg", "millimeter_Hg"), ("mmH2O", "millimeter_H2O"), ("inH2O", "inch_H2O"), ("INH2O", "inch_H2O"),
             ("inHg", "inch_Hg"), ("INHG", "inch_Hg"), ("inhg", "inch_Hg"), ("Torr", "torr"), ("TORR", "torr"),
             ("torr", "torr"), ("mTorr", "millitorr"), ("mtorr", "millitorr"),
             ("inWC", "inch_H2O"), ("inWG", "inch_H2O"), ("INWG", "inch_H2O"), ("mmWG", "millimeter_H2O"),
             ("mmAq", "millimeter_H2O")]


@pytest.mark.parametrize("unit, pint_name", PRESSURES)
@pytest.mark.parametrize("where", ["brackets", "cells"])
def test_vacuum_and_water_gauge_pressures_convert_at_pints_own_factor(unit, pint_name, where):
    """Before: 'UMHG' and 'inWC' were not understood, 'mTorr' read as megatorr or millitorr and refused."""
    text = (_with_header(f"theta,phi,flow,pressure [{unit}],efficiency") if where == "brackets"
            else _with_cell_unit(3, unit))
    loaded = _load(text, {"result_units": {"pressure": "kPa"}})
    (conversion,) = [c for c in loaded.source["conversions"] if c["quantity"] == "pressure"]
    expected = pint.UnitRegistry().Quantity(1.0, pint_name).to("kilopascal").magnitude
    assert conversion["factor"] == pytest.approx(expected, rel=1e-12)
    assert loaded.internal.positions[0].pressure[0] == pytest.approx(1.076 * expected, rel=1e-12)


@pytest.mark.parametrize("written, pint_name", [("UL/MIN", "microliter / minute"), ("uL/min", "microliter / minute")])
def test_a_capital_u_is_read_as_micro_as_upper_case_has_no_mu(written, pint_name):
    """Refused before as not understood: a leading capital is never lowered into a prefix below milli (NL/MIN is not
    nanolitres), but U is no N or S of normal or standard volumes; it is how upper case writes µ."""
    loaded = _load(_with_header(f"theta,phi,flow [{written}],pressure,efficiency"), {"result_units": {"flow": "m3/h"}})
    (conversion,) = [c for c in loaded.source["conversions"] if c["quantity"] == "flow"]
    expected = pint.UnitRegistry().Quantity(1.0, pint_name).to("meter ** 3 / hour").magnitude
    assert conversion["factor"] == pytest.approx(expected, rel=1e-12)


def test_an_ambiguous_unit_after_a_comma_is_refused_naming_its_column():
    """Before: 'pressure, MPA' was no header cell at all ('must name the columns flow, pressure, …')."""
    with pytest.raises(InputRejected) as refused:
        _load(_with_header('theta,phi,flow,"pressure, MPA",efficiency'))
    (error,) = refused.value.errors
    assert "column 'pressure, MPA'" in error.msg and "MPa" in error.msg and "mPa" in error.msg
