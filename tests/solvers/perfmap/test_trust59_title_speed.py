"""The speed unit in a GasTurb map's title is taken only where it is a shaft speed's or a per cent's and the speeds
fit it: a title is free text (GasTurb's own maps, 'Compressor map; flow [kg/s], speed [N/Nd]'), so what reads as no
such unit is left to the speeds' values, not refused; a 'speed [-]' over speeds in rpm still warns implausible_speed;
a 'speed [%]' over speeds 0.45 to 1 reads them as the relative speeds they are, saying so."""

from __future__ import annotations

from pathlib import Path

import pytest

from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.perfmap.cycle_exports import gasturb_tables
from plantsolve.solvers.perfmap.upload import parse_upload
from tests.solvers.perfmap.test_perfmap_exports2 import read_by_gspy
from tests.solvers.perfmap.test_trust59_exports_speed import _fitted

COMPMAP = Path(__file__).parent / "data" / "gasturb" / "compmap.map"  # speeds 0.45 to 1.0


def _read(text: str):
    return parse_upload(StoredInput.from_bytes("map.map", text.encode()), {"map": False})


def _titled(title: str) -> str:
    lines = COMPMAP.read_text().split("\n")
    lines[0] = "99    " + title
    return "\n".join(lines)


def _settings(request) -> dict:
    return next(w for w in request.upload_warnings if w.code == "upload_settings").details


@pytest.mark.parametrize("title", ["Compressor map; flow [kg/s], speed [N/Nd]",
                                   "Fan [rev 3]; flow [kg/s], speed [rel. corr.]",
                                   "Fan; flow [kg/s], speed [kg/s]"])
def test_a_title_speed_text_that_is_no_speed_unit_is_read_by_the_speeds(title):
    request = _read(_titled(title))
    assert request.setting_units == ["1"]
    assert [p.setting[0] for p in request.positions][:2] == pytest.approx([0.45, 0.5])


@pytest.mark.parametrize("unit", ["%", "rpm"])
def test_a_title_unit_that_relative_speeds_contradict_is_not_taken(unit):
    request = _read(_titled(f"Fan; flow [kg/s], speed [{unit}]"))
    assert request.setting_units == ["1"]
    assert _settings(request)["speed"].endswith(f"(the title's {unit} not taken)")


def test_a_dimensionless_title_speed_over_rpm_still_warns_implausible_speed():
    (data,) = gasturb_tables(_fitted("speed [rpm]", 10000.0)).values()
    text = data.decode().replace(", speed [rpm];", ", speed [-];", 1)
    request = _read(text)
    assert "implausible_speed" in {w.code for w in request.upload_warnings}
    assert request.setting_units == [""]


def test_gspy_reads_the_rpm_export_whose_title_states_the_unit(tmp_path):
    fitted = _fitted("speed [rpm]", 10000.0)
    ((_, gsp),) = read_by_gspy(fitted, tmp_path)
    assert "speed [rpm]" in gsp.map_title  # GSPy keeps the title's words, and reads the tables after it as written
    assert gsp.nc_values == pytest.approx([line.setting[-1] for line in fitted.beta_map.lines], rel=5e-7)
