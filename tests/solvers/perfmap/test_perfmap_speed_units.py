"""A shaft speed in a rig's spelling of rpm: 'U/min' (Umdrehungen pro Minute) was read by pint as enzyme units per
minute, 'r/min', 'rev/min' and 'min-1' not at all, so the speed's plausibility check was skipped, no word."""

from __future__ import annotations

import pytest

from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.perfmap.upload import parse_upload
from plantsolve.solvers.perfmap.validation import load
from tests.solvers.perfmap.conftest import DATA

LINES = (DATA / "n3_fan_map.csv").read_text().replace("\r\n", "\n").splitlines()  # theta,phi,flow,pressure,eff
SPEEDS = [float(line.split(",")[1]) for line in LINES[1:]]  # phi: relative speeds, 0.5..1.1
SPELLINGS = ["U/min", "u/min", "1/min", "min^-1", "min-1", "r/min", "rev/min"]


def _codes(header: str, per_design: float, units_row: str | None = None) -> dict:
    rows = [",".join([repr(per_design * float(line.split(",")[1]))] + line.split(",")[2:]) for line in LINES[1:]]
    lines = [header, *([units_row] if units_row else []), *rows]
    source = StoredInput.from_bytes("rig.csv", ("\n".join(lines) + "\n").encode())
    value = load(parse_upload(source, {"map": False}), source)
    return {w.code: w for w in list(value.internal.upload_warnings) + value.warnings}


@pytest.mark.parametrize("unit", SPELLINGS)
def test_a_relative_speed_labelled_in_a_rig_spelling_of_rpm_is_warned_about(unit):
    warning = _codes(f"speed [{unit}],flow,pressure ratio,efficiency", 1.0)["implausible_speed"]
    assert warning.details["values"] == [min(SPEEDS), max(SPEEDS)] and "labelled rpm" in warning.message


@pytest.mark.parametrize("unit", SPELLINGS)
def test_a_shaft_speed_in_a_rig_spelling_of_rpm_is_read_as_rpm(unit):
    assert "implausible_speed" not in _codes(f"speed [{unit}],flow,pressure ratio,efficiency", 5000.0)


def test_a_header_in_u_per_min_over_a_units_row_in_rpm_is_one_unit():
    codes = _codes("speed [U/min],flow,pressure ratio,efficiency", 1.0, "rpm,,,")
    assert codes["implausible_speed"].details["values"] == [min(SPEEDS), max(SPEEDS)]
