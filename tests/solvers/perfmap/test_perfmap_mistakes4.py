"""Mistakes of the fourth probe: an efficiency column in per cent with one row typed as a fraction (or the other way
round) was read with that row 100 times off, and a header unit the row of units under it contradicts was taken
over it without a word."""

from __future__ import annotations

import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.perfmap.upload import parse_upload
from plantsolve.solvers.perfmap.validation import load
from tests.solvers.perfmap.conftest import DATA

ROWS = [[float(x) for x in line.split(",")] for line in
        (DATA / "n3_fan_map.csv").read_text().replace("\r\n", "\n").splitlines()[1:] if line.strip()]
ROWS = [r for r in ROWS if r[0] == 0.0]  # one alpha: a speed line map, 9 lines


def _rig(efficiency=lambda r: f"{r[4] * 100:.2f}", header="speed [rpm],flow [kg/s],PR [-],efficiency [%]",
         units_row: str | None = None) -> str:
    body = [f"{r[1] * 10000:g},{r[2] * 0.45359237:.4f},{r[3]:.4f},{efficiency(r)}" for r in ROWS]
    return "\n".join([header, *([units_row] if units_row else []), *body]) + "\n"


def _load(content: str):
    source = StoredInput.from_bytes("rig.csv", content.encode())
    return load(parse_upload(source, None), source)


ODD = ROWS[5]  # file line 7


@pytest.mark.parametrize("usual, odd, kind", [
    (lambda r: f"{r[4] * 100:.2f}", lambda r: f"{r[4]:.4f}", "a fraction among per cent"),  # was 0.66 % at line 7
    (lambda r: f"{r[4]:.4f}", lambda r: f"{r[4] * 100:.2f}", "a per-cent value among fractions"),  # was all / 100
])
def test_a_percent_efficiency_column_mixing_fractions_and_per_cent_is_refused_naming_the_odd_row(usual, odd, kind):
    with pytest.raises(InputRejected) as refused:
        _load(_rig(lambda r: odd(r) if r is ODD else usual(r)))
    (error,) = refused.value.errors
    assert error.loc == ("file", "row", 7, "efficiency") and kind in error.msg and "'efficiency [%]'" in error.msg


def test_a_percent_column_of_one_kind_still_reads_either_way():
    percent, fractions = _load(_rig()), _load(_rig(lambda r: f"{r[4]:.4f}"))
    flat = [e for p in percent.internal.positions for e in p.efficiency]
    assert flat == pytest.approx([e for p in fractions.internal.positions for e in p.efficiency], abs=1e-4)


def test_a_units_row_contradicting_the_header_is_refused_naming_both():
    with pytest.raises(InputRejected) as refused:  # was read in kg/s, the header's, with no word
        _load(_rig(units_row="rpm,lb/s,-,%"))
    (error,) = refused.value.errors
    assert error.loc == ("file", "header") and "'kg/s'" in error.msg and "'lb/s'" in error.msg and "line 2" in error.msg


@pytest.mark.parametrize("units_row", ["rpm,kg/s,-,%", "[rpm],[kg s^-1],[1],[%]", ",,,", "1/min,kg/s,-,%"])
def test_a_units_row_agreeing_with_the_header_or_empty_is_read(units_row):
    loaded = _load(_rig(units_row=units_row))
    assert loaded.units.flow == "kg/s" and len(loaded.settings) == 9


@pytest.mark.parametrize("header, units_row", [
    ("speed [Hz],flow [lbm/s],PR [-],efficiency [%]", "1/s,lb/s,-,%"),  # refused as contradicting before
    ("speed [rpm],flow [kg/s],PR [-],efficiency (isentropic)", "rpm,kg/s,-,%"),  # refused: 'isentropic' no unit
])
def test_one_unit_spelt_two_ways_or_a_header_parenthesis_that_is_no_unit_is_read(header, units_row):
    loaded = _load(_rig(header=header, units_row=units_row))
    assert len(loaded.settings) == 9 and max(e for p in loaded.internal.positions for e in p.efficiency) < 1


def test_a_real_low_efficiency_in_a_percent_column_is_no_stray_fraction():
    # 1.2 % near choke beside 30-94 %: read as 0.012, not refused as 'a fraction among per cent' (100 x 1.2 = 120
    # lies outside the others' range); an efficiency of 0 is refused as such, not as a fraction
    loaded = _load(_rig(lambda r: "1.20" if r is ODD else f"{r[4] * 100:.2f}"))
    assert min(e for p in loaded.internal.positions for e in p.efficiency) == pytest.approx(0.012)
    with pytest.raises(InputRejected) as refused:
        _load(_rig(lambda r: "0.00" if r is ODD else f"{r[4] * 100:.2f}"))
    assert all("fraction" not in e.msg for e in refused.value.errors)


def test_a_json_request_in_per_cent_with_one_fraction_is_refused_naming_the_value():
    from plantsolve.schemas.perfmap import PerfmapRequest
    from plantsolve.solvers.perfmap.synthetic import request_body
    body = request_body()
    for p in body["positions"]:
        p["efficiency"] = [100 * e for e in p["efficiency"]]
    body["units"] = {"efficiency": "%"}
    assert load(PerfmapRequest.model_validate(body)).internal.positions  # per cent throughout: read
    body["positions"][2]["efficiency"][1] /= 100  # was read as 0.8 %, no word
    with pytest.raises(InputRejected) as refused:
        load(PerfmapRequest.model_validate(body))
    (error,) = refused.value.errors
    assert error.loc == ("positions", 2, "efficiency", 1) and "a fraction among per cent" in error.msg


def _upload(name: str, text: str):
    return parse_upload(StoredInput.from_bytes(name, text.encode()), None)


def test_a_map_point_left_out_is_named_by_table_line_speed_and_beta():
    text = (DATA / "gasturb" / "compmap.map").read_text()
    assert text.splitlines()[21].split()[:3] == ["0.45000", "0.62000", "0.64000"]  # the Efficiency row of speed 0.45
    request = _upload("compmap.map", text.replace("0.64000      0.64000", "nan      0.64000", 1))
    (dropped,) = [w for w in request.upload_warnings if w.code == "upload_points_dropped"]
    # was "1 map point(s) without positive finite values dropped", with no word of where
    assert dropped.details["at"] == [{"table": "Efficiency", "line": 22, "speed": 0.45, "beta": 0.125, "value": "nan"}]
    assert "Efficiency line 22 (speed 0.45, beta 0.125: nan)" in dropped.message


def test_a_pycycle_map_cell_left_out_is_named_by_array_and_index():
    text = (DATA / "pycycle" / "HPC_map.py").read_text()
    request = _upload("HPC_map.py", text.replace(".7276,", "72.76,", 1))  # one efficiency typed in per cent
    (dropped,) = [w for w in request.upload_warnings if w.code == "upload_points_dropped"]
    (at,) = dropped.details["at"]
    assert (at["table"], at["index"][-1], at["value"]) == ("effMap", 1, "72.76") and "effMap[" in dropped.message
