"""Request options of the 48th probe: pressures marked absolute or gauge as process sheets write them ('kPa(a)',
'bar(g)'), which were refused as not understood while 'psia' and 'bara' passed."""

from __future__ import annotations

import pytest

from plantsolve.schemas.perfmap import PerfmapRequest
from plantsolve.solvers.base import InputRejected
from plantsolve.solvers.perfmap.validation import load

FLOWS = [[10.0, 11.0, 12.0, 13.0], [12.0, 13.0, 14.0, 15.0], [14.0, 15.0, 16.0, 17.0]]


def speed_lines(pressure_unit: str, result_pressure: str | None = None, scale: float = 1.0) -> PerfmapRequest:
    positions = [{"setting": [s], "flow": flows, "pressure": [p * scale for p in (1.30, 1.28, 1.24, 1.18)],
                  "efficiency": [0.80, 0.86, 0.88, 0.84]} for s, flows in zip((0.6, 0.7, 0.8), FLOWS)]
    options = {"result_units": {"pressure": result_pressure}} if result_pressure else {}
    return PerfmapRequest.model_validate({"setting_names": ["Nc"], "units": {"flow": "kg/s", "pressure": pressure_unit},
                                          "positions": positions, "options": options})


@pytest.mark.parametrize("given, wanted, factor, stated", [
    ("bar", "kPa(a)", 100.0, "kPa"), ("bar", "bar (abs)", 1.0, "bar"), ("kPa(a)", "psia", 1 / 6.894757, "psia"),
    ("MPa(a)", "kPa", 1000.0, "kPa"), ("bar(g)", "kPa(g)", 100.0, "kPag"), ("kPa gauge", "barg", 0.01, "barg"),
])
def test_a_pressure_marked_absolute_or_gauge_is_read(given, wanted, factor, stated):
    loaded = load(speed_lines(given, wanted))
    assert loaded.units.pressure == stated
    assert loaded.internal.positions[0].pressure[0] == pytest.approx(1.30 * factor, rel=1e-6)


@pytest.mark.parametrize("given, wanted, loc, why", [
    ("bar", "kPa(g)", ("options", "result_units", "pressure"), "gauge"),  # absolute to gauge needs the ambient
    ("Pa(g)", None, ("units", "pressure"), "gauge pressure is read in"),  # no gauge pascals: not read as absolute
    ("kg(a)", None, ("units", "pressure"), "no pressure unit"),
])
def test_a_marked_unit_that_cannot_be_used_is_refused_saying_why(given, wanted, loc, why):
    """Refused before too, as 'not understood' (which told nothing of the mark)."""
    with pytest.raises(InputRejected) as refused:
        load(speed_lines(given, wanted))
    (error,) = refused.value.errors
    assert error.loc == loc and why in error.msg and "not understood" not in error.msg
