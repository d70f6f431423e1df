"""The mistakes users make with rig tables, made as they make them: a header unit its values contradict, locale
numbers, a cut file, absurd values, another kind's file. Each is answered right with a warning naming the column
and its values, or refused naming the column and the lines; never a confident wrong map."""

from __future__ import annotations

import json
import logging

import numpy as np
import pytest

from plantsolve.schemas.perfmap import PerfmapRequest
from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.perfmap import SPEC
from plantsolve.solvers.perfmap.synthetic import request_body
from plantsolve.solvers.perfmap.units import registry
from plantsolve.solvers.perfmap.upload import parse_upload
from plantsolve.solvers.perfmap.validation import load
from tests.conftest import REPO
from tests.solvers.perfmap.conftest import DATA

TEXT = (DATA / "n3_fan_map.csv").read_text().replace("\r\n", "\n")
LINES = TEXT.splitlines()  # header, then 'theta,phi,flow,pressure,efficiency' rows
SPEEDS = [float(line.split(",")[1]) for line in LINES[1:]]  # phi: the relative speed of the N+3 fan's lines


def _table(lines: list[str], name: str = "rig.csv", options=None):
    source = StoredInput.from_bytes(name, ("\n".join(lines) + "\n").encode())
    return load(parse_upload(source, {"map": False, **(options or {})}), source)


def _refusal(content: bytes, name: str = "rig.csv", options=None) -> list:
    source = StoredInput.from_bytes(name, content)
    with pytest.raises(InputRejected) as error:
        load(parse_upload(source, options), source)
    return error.value.errors


def _codes(value) -> dict:
    return {w.code: w for w in list(value.internal.upload_warnings) + value.warnings}


def _efficiencies(value) -> np.ndarray:
    return np.concatenate([p.efficiency for p in value.internal.positions])


@pytest.fixture(scope="module")
def plain():
    return _table(LINES)


def _column(lines: list[str], k: int, change) -> list[str]:
    out = [lines[0]]
    for line in lines[1:]:
        cells = line.split(",")
        cells[k] = change(cells[k])
        out.append(",".join(cells))
    return out


# ---------------------------------------------------------------- a header unit the values contradict

def test_a_percent_header_over_fractions_is_not_divided_again(plain):
    value = _table([LINES[0].replace("efficiency", "efficiency [%]")] + LINES[1:])
    np.testing.assert_array_equal(_efficiencies(value), _efficiencies(plain))  # peak 0.95, not 0.0095
    codes = _codes(value)
    warning = codes["unit_contradicted_by_values"]
    lo, hi = _efficiencies(plain).min(), _efficiencies(plain).max()
    assert warning.details["column"] == "efficiency [%]" and warning.details["values"] == [lo, hi]
    assert "'efficiency [%]'" in warning.message and f"{lo:.4g}..{hi:.4g}" in warning.message
    assert "upload_efficiency_percent" not in codes and "implausible_efficiency" not in codes
    assert value.source["conversions"] == []


def test_a_true_percent_column_keeps_its_conversion_and_states_it(plain):
    lines = _column([LINES[0].replace("efficiency", "efficiency [%]")] + LINES[1:], 4,
                    lambda c: f"{100 * float(c):.2f}")
    value = _table(lines)
    np.testing.assert_allclose(_efficiencies(value), _efficiencies(plain), rtol=1e-12, atol=1e-12)
    codes = _codes(value)
    assert "upload_efficiency_percent" in codes and "unit_contradicted_by_values" not in codes
    (conversion,) = value.source["conversions"]
    assert conversion == {"quantity": "efficiency", "column": "efficiency [%]", "from_unit": "%", "to_unit": "1",
                          "factor": 0.01, "basis": "header"}


def test_a_fraction_header_over_percent_is_read_as_percent(plain):
    lines = _column([LINES[0].replace("efficiency", "efficiency [-]")] + LINES[1:], 4,
                    lambda c: f"{100 * float(c):.2f}")
    value = _table(lines)
    np.testing.assert_allclose(_efficiencies(value), _efficiencies(plain), rtol=1e-12, atol=1e-12)
    assert _codes(value)["unit_contradicted_by_values"].details["reading"] == "per cent, divided by 100"
    assert value.source["conversions"][0]["basis"] == "values"


def test_a_percent_speed_holding_fractions_is_stated_as_a_fraction():
    lines = ["speed [%],flow,pressure ratio,efficiency"] + [",".join(line.split(",")[1:]) for line in LINES[1:]]
    value = _table(lines)
    assert value.units.settings == ["1"]
    warning = _codes(value)["unit_contradicted_by_values"]
    assert warning.details["column"] == "speed [%]" and warning.details["values"] == [min(SPEEDS), max(SPEEDS)]
    assert "implausible_speed" not in _codes(value)


def test_a_json_request_stating_percent_over_fractions_is_not_divided_again():
    body = request_body(n_theta=2, n_phi=3)
    body["units"] = {"efficiency": "%"}
    value = load(PerfmapRequest.model_validate(body))
    assert _efficiencies(value).max() > 0.5 and "unit_contradicted_by_values" in _codes(value)


# ---------------------------------------------------------------- locale numbers

def test_thousands_separators_quoted_or_not_are_read(plain):
    grouped = _column(LINES, 2, lambda c: f"{float(c):,.4f}")
    quoted = _column(LINES, 2, lambda c: f'"{float(c):,.4f}"')
    for lines in (quoted, grouped):
        value = _table(lines)
        flows = np.concatenate([p.flow for p in value.internal.positions])
        np.testing.assert_allclose(flows, np.concatenate([p.flow for p in plain.internal.positions]), rtol=1e-12)
    thousands = sum(float(line.split(",")[2]) >= 1000 for line in LINES[1:])
    assert thousands > 100 and _codes(_table(grouped))["upload_thousands_separators"].details["count"] == thousands


def test_decimal_commas_in_a_semicolon_file_are_read(plain):
    lines = [line.replace(",", ";").replace(".", ",") for line in LINES]
    value = _table(lines)
    np.testing.assert_allclose(_efficiencies(value), _efficiencies(plain), rtol=1e-12)


def test_numbers_that_read_two_ways_are_refused_naming_the_column_the_pattern_and_the_lines():
    # a ';' file whose only decimals are '1,104'-like: 1.104 or 1104? nothing in the file says which
    lines = ["speed;flow;pressure ratio;efficiency", "1;1,104;2;1", "1;1,247;2;1", "1;1,384;2;1"]
    errors = _refusal(("\n".join(lines) + "\n").encode())
    (error,) = errors
    assert error.loc == ("file", "row", 2, "flow") and error.type == "ambiguous_number"
    assert "'flow'" in error.msg and "'1,104'" in error.msg and "2, 3 and 4" in error.msg
    assert "1.104" in error.msg and "1104" in error.msg


def test_a_column_mixing_decimal_points_and_commas_is_refused_naming_the_minority_lines():
    lines = [line.replace(",", ";") for line in LINES]
    cells = lines[7].split(";")
    lines[7] = ";".join(cells[:4] + [cells[4].replace(".", ",")])  # one efficiency with a decimal comma
    (error,) = _refusal(("\n".join(lines) + "\n").encode())
    assert error.loc[:3] == ("file", "row", 8) and "line 8" in error.msg and "mixes" in error.msg


def test_a_row_split_by_an_unreadable_separator_names_that_line_only():
    lines = list(LINES)
    lines[4] = "0.0,0.5,1,5,1.07,0.88"  # an unquoted decimal comma: six cells
    value = _table(lines)
    warning = _codes(value)["upload_rows_skipped"]
    assert warning.details["lines"] == [5] and "6 cells" in warning.message


# ---------------------------------------------------------------- cut files

def test_a_file_cut_inside_its_last_number_warns_and_drops_that_row(plain):
    at = next(i for i, line in enumerate(LINES) if line.endswith("0.9278"))  # 42 % in
    cut = "\n".join(LINES[:at]) + "\n" + LINES[at][:-3]  # 0.9278 -> 0.9, no line ending
    source = StoredInput.from_bytes("rig.csv", cut.encode())
    value = load(parse_upload(source, {"map": False}), source)
    warning = _codes(value)["truncated_file"]
    assert warning.details["line"] == at + 1 and warning.details["value"] == "0.9"
    assert warning.details["decimals"] == 1 and warning.details["column_decimals"][0] >= 2
    assert sum(len(p.flow) for p in value.internal.positions) == at - 1  # the cut row is not read
    result = SPEC.solve(value).result
    assert result.report.status == "warning" and "truncated_file" in {w.code for w in result.report.warnings}


def test_a_short_last_row_without_a_line_ending_warns():
    cut = "\n".join(LINES[:-1]) + "\n" + ",".join(LINES[-1].split(",")[:3])
    source = StoredInput.from_bytes("rig.csv", cut.encode())
    warning = _codes(load(parse_upload(source, {"map": False}), source))["truncated_file"]
    assert warning.details["line"] == len(LINES) and warning.details["cells"] == 3
    assert warning.details["header_cells"] == 5


def test_a_whole_file_without_a_final_line_ending_is_no_cut(plain):
    source = StoredInput.from_bytes("rig.csv", "\n".join(LINES).encode())
    assert "truncated_file" not in _codes(load(parse_upload(source, {"map": False}), source))


# ---------------------------------------------------------------- plausibility

@pytest.mark.parametrize("header, change, code, mixup", [
    ("theta,phi,flow [kg/s],pressure,efficiency", None, None, None),
    ("theta,phi,flow [kg/s],pressure,efficiency", lambda c: str(float(c) * 1000), "implausible_flow", "g/s"),
    ("theta,phi,flow,pressure ratio,efficiency", lambda c: str(1 / float(c)), "implausible_pressure_ratio",
     "inverse ratio"),
    ("theta,phi,flow,pressure [kPa],efficiency", lambda c: str(float(c) * 101325), "implausible_pressure", "Pa read"),
])
def test_implausible_flows_and_pressures_are_warned_about(header, change, code, mixup):
    k = 2 if "flow [" in header and change is not None and code == "implausible_flow" else 3
    lines = [header] + LINES[1:]
    if change is not None:
        lines = _column(lines, k, change)
    codes = _codes(_table(lines))
    found = {c for c in codes if c.startswith("implausible_")}
    assert found == ({code} if code else set())
    if code:
        assert mixup in codes[code].message and codes[code].details["range"] if "range" in codes[code].details \
            else mixup in codes[code].message


@pytest.mark.parametrize("header", ["theta,phi,flow,pressure,efficiency", "theta,phi,flow [lbm/s],pressure,efficiency"])
def test_a_stray_minus_on_one_flow_is_warned_about_naming_the_value_and_its_setting(header):
    """Line 2's flow 1104.338 written -1104.338: fitted as given, the speed line and map reach to negative flow."""
    lines = [header, LINES[1].replace("0.0,0.5,", "0.0,0.5,-", 1)] + LINES[2:]
    assert lines[1].split(",")[2] == "-1104.338"
    warning = _codes(_table(lines))["implausible_flow"]
    assert warning.details["values"] == [-1104.338] and len(warning.details["settings"]) == 1
    assert "-1104.34" in warning.message and "minus" in warning.message
    assert "implausible_flow" not in _codes(_table([header] + LINES[1:]))


@pytest.mark.parametrize("name", ["bigfanc.map", "compmap.map"])
def test_a_published_map_whose_low_speed_lines_dip_below_a_ratio_of_one_is_not_called_inverted(name):
    """GasTurb's own maps run to PR 0.94 at low speed towards choke: no 'inverse ratio' warning for them, while the
    same N+3 file with every ratio made a rise (PR - 1) still gets it."""
    source = StoredInput.from_bytes(name, (DATA / "gasturb" / name).read_bytes())
    value = load(parse_upload(source, {"map": False}), source)
    assert min(float(np.min(p.pressure)) for p in value.internal.positions) < 1
    assert "implausible_pressure_ratio" not in _codes(value)
    rise = _column(["theta,phi,flow,pressure ratio,efficiency"] + LINES[1:], 3, lambda c: str(float(c) - 1))
    assert "pressure rise" in _codes(_table(rise))["implausible_pressure_ratio"].message


def test_an_efficiency_divided_twice_is_warned_about():
    lines = _column(LINES, 4, lambda c: str(float(c) / 100))
    warning = _codes(_table(lines))["implausible_efficiency"]
    assert "divided by 100 again" in warning.message and max(warning.details["peaks"]) < 0.2


def test_a_relative_speed_labelled_rpm_is_warned_about():
    lines = ["speed [rpm],flow,pressure ratio,efficiency"] + [",".join(line.split(",")[1:]) for line in LINES[1:]]
    warning = _codes(_table(lines))["implausible_speed"]
    assert warning.details["values"] == [min(SPEEDS), max(SPEEDS)] and "labelled rpm" in warning.message


@pytest.mark.parametrize("unit, per_design, warned", [
    ("Hz", 10.0, False),       # 5-11 Hz = 300-660 rpm (read as radians per second: 48-105, warned)
    ("1/min", 500.0, False),   # 250-550 rpm as German rigs write it (read as radians: 40-88, warned)
    ("1/s", 1.0, True),        # 0.5-1.1 revolutions a second: the relative speed labelled 1/s
    ("rad/s", 20.0, True),     # 10-22 rad/s = 95-210 rpm
])
def test_a_shaft_speed_in_a_frequency_counts_revolutions(unit, per_design, warned):
    lines = [f"speed [{unit}],flow,pressure ratio,efficiency"] + [
        ",".join([str(per_design * float(line.split(",")[1]))] + line.split(",")[2:]) for line in LINES[1:]]
    codes = _codes(_table(lines))
    rpm = {"Hz": 60.0, "1/min": 1.0, "1/s": 60.0, "rad/s": 60 / (2 * np.pi)}[unit]
    low = per_design * min(SPEEDS) * rpm
    assert ("implausible_speed" in codes) == (low < 100.0) == warned
    if warned:
        assert codes["implausible_speed"].details["values"][0] == pytest.approx(low)


# ---------------------------------------------------------------- files of another kind

@pytest.mark.parametrize("name, content, held", [
    ("scan.csv", b"0.0 0.0 0.0\n1.0 0.5 0.2\n2.0 1.0 0.4\n3.0 1.5 0.6\n", "XYZ point cloud"),
    ("scan.csv", b"x,y,z\n0,0,0\n1,0.5,0.2\n2,1,0.4\n", "point cloud"),
    ("nominal.csv", b"L,R,A,CLR\n100,0,90,50\n200,90,45,50\n", "bending table"),
    ("nominal_lra.csv", (REPO / "examples" / "tube" / "nominal_lra.csv").read_bytes(), "bending table"),
    ("nominal_xyz_clr.csv", (REPO / "examples" / "tube" / "nominal_xyz_clr.csv").read_bytes(), "x, y, z"),
    ("scan.csv", (REPO / "examples" / "tube" / "scan.xyz").read_bytes(), "XYZ point cloud"),
    ("offices.csv", b"Version,9.6;\n\nZone,\n  Office 1;  !- Name\n", "EnergyPlus IDF"),
    ("line.csv", b"ISOGEN-FILES ISOGEN.FLS\nUNITS-BORE MM\nPIPE\n", "PCF"),
])
def test_a_file_of_another_kind_is_refused_naming_what_it_holds(name, content, held):
    (error,) = _refusal(content, name)
    assert error.loc == ("file",) and held in error.msg and error.type == "wrong_kind"


def test_another_kinds_json_request_is_refused_naming_the_kind():
    (error,) = _refusal(json.dumps({"units": "mm", "pipe": {"radius": 50}}).encode(), "meter.json")
    assert "flowmeter request" in error.msg and "/v1/flowmeter/jobs" in error.msg


# ---------------------------------------------------------------- one load per job, no pint noise

def test_the_table_is_prepared_once_for_check_solve_and_artifacts(monkeypatch):
    from plantsolve.solvers.perfmap import validation as loading

    calls = []
    real = loading.prepare
    monkeypatch.setattr(loading, "prepare", lambda *a, **k: calls.append(1) or real(*a, **k))
    source = StoredInput.from_bytes("rig.csv", ("\n".join(LINES[:30]) + "\n").encode())
    value = SPEC.input_of(SPEC.parse_upload(source, {"map": False, "grid": [8, 8]}), source)
    SPEC.check_input(value)
    solved = SPEC.solve(value)
    SPEC.render_artifacts(value, solved)
    assert calls == [1]
    assert solved.result.report.details["source"]["format"] == "csv"


def test_building_the_unit_registry_logs_no_redefinition(caplog):
    registry.cache_clear()
    with caplog.at_level(logging.WARNING):
        reg = registry()
    assert not [r for r in caplog.records if "Redefin" in r.getMessage()]
    assert reg.Quantity(5, "permille").to("dimensionless").magnitude == pytest.approx(0.005)
    assert reg.Quantity(1, "lbm/s").to("kg/s").magnitude == pytest.approx(0.45359237)


def test_a_workbook_with_a_percent_header_over_fractions_is_read_as_fractions(plain):
    import io

    import openpyxl

    book = openpyxl.Workbook()
    sheet = book.active
    sheet.title = "Map"
    sheet.append(["theta", "phi", "flow", "pressure", "Efficiency [%]"])
    for line in LINES[1:]:
        sheet.append([float(v) for v in line.split(",")])
    buffer = io.BytesIO()
    book.save(buffer)
    source = StoredInput.from_bytes("rig.xlsx", buffer.getvalue())
    value = load(parse_upload(source, {"map": False}), source)
    np.testing.assert_array_equal(_efficiencies(value), _efficiencies(plain))
    assert _codes(value)["unit_contradicted_by_values"].details["column"] == "Efficiency [%]"
    assert value.request.source.format == "xlsx" and value.request.source.row_label == "sheet 'Map' row"
