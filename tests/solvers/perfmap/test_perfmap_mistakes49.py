"""Mistakes of the 49th probe: a unit written in upper case ('KG/S', 'KPA', 'PSI' as old rig software writes them)
refused as not understood, or read as another quantity ('PA' petaamperes under a pressure, 'T/H' teslas per henry
under a flow) and refused for its dimensions; an upper-case unit that reads as two ('MPA': MPa or mPa) must be refused,
never guessed. A minimax fit whose linear programme fails ran least squares while `pressure_fit` said 'minimax'.
Refitting our own curves.csv with `model: auto`: what it gives and why."""

from __future__ import annotations

import json
import sys

import numpy as np
import pytest

from plantsolve.schemas.perfmap import PerfmapRequest
from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.perfmap import fitting
from plantsolve.solvers.perfmap.artifacts import curves_csv
from plantsolve.solvers.perfmap.solve import solve
from plantsolve.solvers.perfmap.upload import parse_upload
from plantsolve.solvers.perfmap.validation import load
from tests.conftest import REPO
from tests.solvers.perfmap.conftest import DATA

N3 = (DATA / "n3_fan_map.csv").read_text()
HEADER = "theta,phi,flow,pressure,efficiency"


def _load(header: str, units_row: str | None = None, options=None):
    text = N3.replace(HEADER, header + (f"\n{units_row}" if units_row else ""), 1)
    source = StoredInput.from_bytes("rig.csv", text.encode())
    return load(parse_upload(source, {"map": False, **(options or {})}), source)


@pytest.mark.parametrize("header, flow, pressure", [
    ("theta,phi,flow [KG/S],pressure [KPA],efficiency", "kg/s", "kPa"),  # refused before: 'not understood'
    ("theta,phi,flow [LBM/S],pressure [PSI],efficiency", "lbm/s", "psi"),
    ("theta,phi,Flow [Kg/s],pressure [BAR],efficiency", "kg/s", "bar"),
    ("theta,phi,flow [M3/H],pressure [PA],efficiency", "m³/h", "Pa"),  # 'PA' was petaamperes: not a pressure
    ("theta,phi,flow [T/H],pressure [KPA(A)],efficiency", "t/h", "kPa"),  # 'T/H' was teslas per henry
    ("theta,phi,flow [G/S],pressure [BAR(G)],efficiency", "g/s", "barg"),  # 'G/S' was gauss per siemens
    # a marked pressure in a header: 'missing: pressure' before (the mark's bracket hid the unit's)
    ("theta,phi,flow [kg/s],pressure [kPa(a)],efficiency", "kg/s", "kPa"),
    ('theta,phi,flow [kg/s],"pressure, bar(g)",efficiency', "kg/s", "barg"),
    ("theta,phi,Flow / (kg/s),pressure (psi (a)),efficiency", "kg/s", "psi"),
])
def test_a_unit_in_upper_case_is_read_in_the_one_case_that_fits_its_column(header, flow, pressure):
    loaded = _load(header)
    assert (loaded.units.flow, loaded.units.pressure) == (flow, pressure)
    first = loaded.internal.positions[0]
    assert (first.flow[0], first.pressure[0]) == (1104.338, 1.076)  # kept in the stated unit, nothing scaled


def test_an_upper_case_unit_converts_as_its_own_case_does():
    upper = _load("theta,phi,flow [LBM/S],pressure [BAR],efficiency", options={"result_units": {"flow": "KG/S",
                                                                                               "pressure": "KPA"}})
    assert (upper.units.flow, upper.units.pressure) == ("kg/s", "kPa")
    assert upper.internal.positions[0].flow[0] == pytest.approx(1104.338 * 0.45359237, rel=1e-12)
    assert upper.internal.positions[0].pressure[0] == pytest.approx(107.6, rel=1e-12)


@pytest.mark.parametrize("unit, readings", [("MPA", ("MPa", "mPa")), ("MBAR", ("Mbar", "mbar")),
                                            ("MPA(A)", ("MPa", "mPa"))])
def test_an_upper_case_unit_of_two_readings_is_refused_naming_both(unit, readings):
    """MPa and mPa differ by 1e9: a guess would be a confident wrong pressure."""
    with pytest.raises(InputRejected) as refused:
        _load(f"theta,phi,flow,pressure [{unit}],efficiency")
    (error,) = refused.value.errors
    assert error.loc == ("file", "header") and f"pressure [{unit}]" in error.msg
    assert all(r in error.msg for r in readings) and "case" in error.msg


@pytest.mark.parametrize("unit, stated, factor", [("MPa", "MPa", 1e3), ("mPa", "mPa", 1e-6), ("Mbar", "Mbar", 1e8)])
def test_a_unit_written_in_its_own_case_is_never_recased(unit, stated, factor):
    loaded = _load(f"theta,phi,flow,pressure [{unit}],efficiency", options={"result_units": {"pressure": "kPa"}})
    conversion, = [c for c in loaded.source["conversions"] if c["quantity"] == "pressure"]
    assert conversion["from_unit"] == stated and conversion["factor"] == pytest.approx(factor, rel=1e-12)


def test_a_units_row_in_upper_case_agrees_with_the_header():
    loaded = _load("theta,phi,flow [kg/s],pressure [bar],efficiency", units_row="-,-,KG/S,BAR,-")
    assert (loaded.units.flow, loaded.units.pressure) == ("kg/s", "bar")


def test_json_units_in_upper_case():
    body = json.loads((REPO / "examples" / "perfmap" / "n3_fan_map.json").read_text())
    body["units"] = {"flow": "LBM/S", "pressure": "PA", "efficiency": "-"}
    loaded = load(PerfmapRequest.model_validate(body))
    assert (loaded.units.flow, loaded.units.pressure) == ("lbm/s", "Pa")
    body["units"]["pressure"] = "MPA"
    with pytest.raises(InputRejected) as refused:
        load(PerfmapRequest.model_validate(body))
    assert [e.loc for e in refused.value.errors] == [("units", "pressure")]


def _rising_line_request(fit: str) -> PerfmapRequest:
    """Two speed lines, the first rising 18 % towards surge (the axi3_2 pattern that least squares cannot bring
    within 1 % of its floor)."""
    t = np.linspace(0.0, 1.0, 8)
    flow = 20.0 + 9.0 * t
    pressure = 3.0 * np.where(t < 0.4, 1.0 - 0.18 * ((t - 0.4) / 0.4) ** 2, 1.0 - 0.4 * ((t - 0.4) / 0.6) ** 2)
    eta = 0.85 - 0.3 * (t - 0.5) ** 2
    return PerfmapRequest.model_validate({"setting_names": ["Nc"], "options": {"map": False, "fit": fit}, "positions": [
        {"setting": [0.9], "flow": flow.tolist(), "pressure": pressure.tolist(), "efficiency": eta.tolist()},
        {"setting": [1.0], "flow": (flow + 2).tolist(), "pressure": (3.2 - 0.8 * t ** 2).tolist(),
         "efficiency": eta.tolist()}]})


@pytest.fixture()
def failing_highs(monkeypatch):
    """HiGHS answering the fits' linear programmes with 'numerical difficulties' (status 4), as it does on hopeless
    scalings; the floor's programme still solves, so the floor is the true one."""
    class Failed:
        status, x = 4, None

    solve_lp = fitting.linprog

    def linprog(*args, **kwargs):
        return Failed() if sys._getframe(1).f_code.co_name == "_minimax_lp" else solve_lp(*args, **kwargs)

    monkeypatch.setattr(fitting, "linprog", linprog)


def test_a_minimax_fit_whose_programme_fails_says_least_squares_ran(failing_highs):
    result = solve(_rising_line_request("minimax")).result
    assert [s.pressure_fit for s in result.settings] == ["least_squares", "least_squares"]  # was 'minimax'
    said = [w for w in result.report.warnings if w.code == "pressure_fit_not_minimax"]
    assert [w.details["values"] for w in said] == [[0.9], [1.0]]
    assert all(w.details["fit"] == "least_squares" and w.details["asked"] == "minimax" for w in said)
    # what ran is the least-squares fit itself: the same error as a least-squares request
    plain = solve(_rising_line_request("least_squares")).result
    for a, b in zip(result.settings, plain.settings):
        if a.family == b.family:
            assert a.pressure_max_rel_error == pytest.approx(b.pressure_max_rel_error, rel=1e-9)


def test_auto_whose_minimax_fallback_fails_claims_no_minimax(failing_highs):
    result = solve(_rising_line_request("least_squares")).result
    assert all(s.pressure_fit == "least_squares" for s in result.settings)
    assert not [w for w in result.report.warnings if w.code == "pressure_fit_minimax"]
    assert result.report.details["family_choice"]["settings_fitted_by_minimax"] == 0
    (poor,) = [w for w in result.report.warnings if w.code == "pressure_fit_poor"]
    assert poor.details["reason"] == "minimax_not_converged" and poor.details["fit"] == "least_squares"


def test_the_minimax_fallback_still_runs_when_highs_works():
    result = solve(_rising_line_request("least_squares")).result
    assert result.settings[0].pressure_fit == "minimax" and result.settings[0].pressure_excess <= 0.01
    assert not [w for w in result.report.warnings if w.code == "pressure_fit_not_minimax"]


def test_refitting_our_curves_csv_keeps_each_line_within_its_stated_error():
    """curves.csv samples each fitted line at 51 flows, so its floor is 0 and 'auto' keeps the shared family
    wherever it comes within 1 % of it (the rule that picked it on the rig's data). A line first fitted by the shared
    family refits exactly; a line first fitted by another family (the rig's data missed by the shared family by
    more than 1 % above its floor) is refitted by the shared family within 1 % or by a family that reaches it: the
    family may differ, the stated error is the refit's own."""
    body = json.loads((REPO / "examples" / "perfmap" / "n3_fan_map.json").read_text())
    body["options"] = {**body["options"], "map": False}
    body["positions"] = body["positions"][:9]  # theta 0: a spline3, log and concave line among them
    first = solve(PerfmapRequest.model_validate(body)).result
    again = solve(parse_upload(StoredInput.from_bytes("curves.csv", curves_csv(first)),
                               {"map": False, "columns": {"t [-]": "ignore"}})).result
    shared = first.report.details["family_choice"]
    assert {s.family for s in first.settings} >= {"spline3", "log", "concave"}
    assert min(shared["mean_pressure_loo"], key=shared["mean_pressure_loo"].get) == "spline3"
    for a, b in zip(first.settings, again.settings):
        assert b.floor == 0.0 and b.pressure_max_rel_error <= 0.01
        if a.family == "spline3":
            assert b.family == "spline3" and b.pressure_max_rel_error < 1e-6


def _speed_lines(speeds, header="Nc,flow [kg/s],PR,efficiency") -> str:
    rows = [f"{s:g},{f + 0.5 * k:g},{base - 0.02 * k * k:g},{0.8 + 0.02 * k - 0.01 * k * k:g}"
            for s, base in zip(speeds, (1.0, 1.2, 1.4)) for k, f in enumerate((10, 11, 12, 13))]
    return "\n".join([header, *rows]) + "\n"


@pytest.mark.parametrize("speeds, header, says", [
    ((-0.8, -0.9, -1.0), "Nc,flow [kg/s],PR,efficiency", "negative speeds"),  # a flipped sign: said nothing
    ((0.0, 0.9, 1.0), "speed,flow [kg/s],PR,efficiency", "zero"),
    ((-8000.0, 9000.0, 10000.0), "speed [rpm],flow [kg/s],PR,efficiency", "negative speeds"),  # a stray minus
])
def test_a_speed_line_at_no_or_negative_speed_is_warned_naming_the_setting(speeds, header, says):
    source = StoredInput.from_bytes("rig.csv", _speed_lines(speeds, header).encode())
    loaded = load(parse_upload(source, {"map": False}), source)
    (warning,) = [w for w in loaded.warnings if w.code == "implausible_speed"]
    assert warning.details["quantity"] == loaded.request.setting_names[0]
    assert warning.details["values"] == [min(speeds), max(speeds)] and says in warning.message
    positive = StoredInput.from_bytes("rig.csv", _speed_lines([abs(s) or 0.8 for s in speeds], header).encode())
    assert not [w for w in load(parse_upload(positive, {"map": False}), positive).warnings
                if w.code == "implausible_speed"]


def test_our_map_csv_uploaded_as_a_rig_table_is_refused_saying_what_it_is():
    """The job's map.csv (the best-efficiency grid) sent back instead of curves.csv: refused as 'missing:
    efficiency', which told nothing of the mix-up."""
    from plantsolve.solvers.perfmap.artifacts import map_csv

    body = json.loads((REPO / "examples" / "perfmap" / "n3_fan_map.json").read_text())
    body["options"] = {**body["options"], "grid": [12, 10]}
    body["positions"] = body["positions"][:3] + body["positions"][9:12]  # two IGV angles, three speeds each
    exported = map_csv(solve(PerfmapRequest.model_validate(body)).result)
    assert exported.decode().splitlines()[0].startswith("flow [lbm/s],pressure [-],max efficiency [-],optimal theta")
    with pytest.raises(InputRejected) as refused:
        parse_upload(StoredInput.from_bytes("map.csv", exported), {"map": False})
    (error,) = refused.value.errors
    assert error.loc == ("file", "header") and "map.csv" in error.msg and "curves.csv" in error.msg


def test_a_column_mapping_that_names_no_header_is_said_not_silently_dropped():
    """options.columns {'Qx': 'flow'} over a file without 'Qx': the file's own 'flow' column was read without a word
    (the user meant another column); and a refusal for a missing column did not say the mapping matched nothing."""
    text = _speed_lines((0.8, 0.9, 1.0), "Nc,flow [kg/s],PR,efficiency")
    request = parse_upload(StoredInput.from_bytes("rig.csv", text.encode()), {"map": False, "columns": {"Qx": "flow"}})
    (note,) = [w for w in request.upload_warnings if w.code == "upload_columns_unmatched"]
    assert note.details == {"columns": {"Qx": "flow"}, "headers": ["Nc", "flow [kg/s]", "PR", "efficiency"]}
    matched = parse_upload(StoredInput.from_bytes("rig.csv", text.encode()),
                           {"map": False, "columns": {"FLOW [KG/S]": "flow"}})  # matched in any case
    assert not [w for w in matched.upload_warnings or [] if w.code == "upload_columns_unmatched"]
    with pytest.raises(InputRejected) as refused:
        parse_upload(StoredInput.from_bytes("rig.csv", text.replace("flow [kg/s]", "Q").encode()),
                     {"columns": {"q [m3/h]": "flow"}})
    (error,) = refused.value.errors
    assert "missing: flow" in error.msg and "options.columns names no header of the file: 'q [m3/h]'" in error.msg


@pytest.mark.parametrize("word", ["ALPHA", "MASS", "ETA", "FLOW", "SPEED"])
def test_a_word_in_capitals_is_not_recased_into_a_dimensionless_constant(word):
    """'alpha' is pint's fine-structure constant and 'mas' its milliarcsecond: a row of capitalised words under a
    header must not read as a row of units."""
    from plantsolve.solvers.perfmap.units import UnitError, parse_unit

    with pytest.raises(UnitError):
        parse_unit(word)
    assert parse_unit("DEG").text == "deg" and parse_unit("PERCENT").text == "%"


def test_rows_and_columns_in_another_order_give_the_same_map_to_the_last_bit():
    """A rig table sorted otherwise (rows shuffled, columns permuted, units in upper case): the same settings, the
    same coefficients and the same map, bit for bit."""
    import random

    lines = [line.split(",") for line in N3.splitlines()]
    header = lines[0]
    rows = [row for row in lines[1:] if row[0] in ("0.0", "5.0") and row[1] in ("0.5", "0.7", "0.9")]
    shuffled = rows[:]
    random.Random(7).shuffle(shuffled)
    order = [4, 2, 0, 3, 1]

    def solved(head, body):
        text = "\n".join(",".join(cells) for cells in [head, *body]) + "\n"
        return solve(parse_upload(StoredInput.from_bytes("rig.csv", text.encode()), {"grid": [12, 10]})).result

    first = solved([*header[:2], "flow [kg/s]", "pressure [bar]", "efficiency"], rows)
    again = solved([["theta", "phi", "FLOW [KG/S]", "PRESSURE [BAR]", "EFFICIENCY"][k] for k in order],
                   [[r[k] for k in order] for r in shuffled])
    assert [s.setting for s in again.settings] == [s.setting for s in first.settings] and len(first.settings) == 6
    assert [s.pressure_coefficients for s in again.settings] == [s.pressure_coefficients for s in first.settings]
    assert [s.efficiency_coefficients for s in again.settings] == [s.efficiency_coefficients for s in first.settings]
    assert again.map.efficiency == first.map.efficiency and again.units == first.units


@pytest.mark.parametrize("unit, stated, to_m3_per_h", [
    ("cfm", "cfm", 0.3048 ** 3 * 60), ("CFM", "cfm", 0.3048 ** 3 * 60), ("ACFM", "acfm", 0.3048 ** 3 * 60),  # pint: centifermis
    ("gpm", "gpm", 0.003785411784 * 60),
])
def test_a_fan_rigs_cubic_feet_per_minute_is_a_volume_flow(unit, stated, to_m3_per_h):
    loaded = _load(f"theta,phi,flow [{unit}],pressure,efficiency", options={"result_units": {"flow": "m3/h"}})
    (conversion,) = [c for c in loaded.source["conversions"] if c["quantity"] == "flow"]
    assert conversion["from_unit"] == stated and conversion["factor"] == pytest.approx(to_m3_per_h, rel=1e-9)


@pytest.mark.parametrize("unit", ["SCFM", "scfm", "Nm3/h", "Nm³/h", "Sm3/h", "MMSCFD"])
def test_a_flow_at_standard_conditions_is_refused_saying_it_is_a_mass_flow(unit):
    """'Nm3/h' was 'not understood' and 'SCFM' read as nothing: a standard volume is a mass flow in disguise, and
    converting it as an actual volume would be off by the density ratio."""
    with pytest.raises(InputRejected) as refused:
        _load(f"theta,phi,flow [{unit}],pressure,efficiency")
    (error,) = refused.value.errors
    assert error.loc == ("file", "header") and "standard (normal) conditions" in error.msg


@pytest.mark.parametrize("unit, stated", [("INH2O", "inH2O"), ("inh2o", "inH2O")])
def test_a_water_column_in_capitals_is_read(unit, stated):
    assert _load(f"theta,phi,flow,pressure [{unit}],efficiency").units.pressure == stated
