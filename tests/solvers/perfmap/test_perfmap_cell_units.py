"""Cells that state their unit, as Excel shows them and writes them to CSV: a percentage-formatted efficiency
(0.8585 shown 85.85 %), '85.85%' typed as text, a number format writing a unit after the number (0.00" kg/s").
Each is read as the sheet shows it, or refused naming the column where it contradicts the header."""

from __future__ import annotations

import io

import numpy as np
import openpyxl
import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.perfmap.synthetic import speed_lines
from plantsolve.solvers.perfmap.upload import parse_upload
from plantsolve.solvers.perfmap.validation import load
from plantsolve.solvers.perfmap.workbook import format_unit

LINES = speed_lines(3, 6, steep=6.0)["positions"]
EFFICIENCY = np.concatenate([p["efficiency"] for p in LINES])
FLOW = np.concatenate([p["flow"] for p in LINES])


def rows(speed=lambda s: s, flow=lambda f: f, efficiency=lambda e: e):
    return [[speed(p["setting"][0]), flow(f), q, efficiency(e)]
            for p in LINES for f, q, e in zip(p["flow"], p["pressure"], p["efficiency"])]


def workbook(header, table, formats=(None, None, None, None)) -> bytes:
    wb = openpyxl.Workbook()
    ws = wb.active
    ws.append(header)
    for row in table:
        ws.append(row)
        for j, fmt in enumerate(formats, start=1):
            if fmt:
                ws.cell(row=ws.max_row, column=j).number_format = fmt
    buf = io.BytesIO()
    wb.save(buf)
    return buf.getvalue()


def csv(header, table) -> bytes:
    return ("\n".join([",".join(header)] + [",".join(c if isinstance(c, str) else repr(c) for c in r) for r in table])
            + "\n").encode()


def read(name, content):
    return load(parse_upload(StoredInput.from_bytes(name, content), None))


def efficiencies(loaded):
    return np.concatenate([p.efficiency for p in loaded.internal.positions])


def codes(loaded):
    return {w.code for w in loaded.warnings} | {w.code for w in loaded.request.upload_warnings or []}


@pytest.mark.parametrize("unit", ["Efficiency [%]", "Efficiency", "Efficiency [-]"])
def test_a_percentage_formatted_efficiency_is_read_as_excel_shows_it(unit):
    loaded = read("rig.xlsx", workbook(["Speed", "Flow [kg/s]", "PR", unit], rows(), (None, None, None, "0.00%")))
    assert efficiencies(loaded) == pytest.approx(EFFICIENCY, rel=1e-12)
    # 85.85 % in a per-cent column is no contradiction (main warned that the values were fractions)
    assert "unit_contradicted_by_values" not in codes(loaded)


def test_percentage_cells_beside_general_cells_in_a_per_cent_column_are_one_reading():
    # a row typed 85.85 (General) among cells formatted 0.00% holding 0.8585: Excel shows 85.85 % on every row
    table = [r if k % 3 else r[:3] + [100 * r[3]] for k, r in enumerate(rows())]
    formats = [(None, None, None, "0.00%" if k % 3 else None) for k in range(len(table))]
    wb = openpyxl.Workbook()
    ws = wb.active
    ws.append(["Speed", "Flow [kg/s]", "PR", "Efficiency [%]"])
    for row, fmt in zip(table, formats):
        ws.append(row)
        if fmt[3]:
            ws.cell(row=ws.max_row, column=4).number_format = fmt[3]
    buf = io.BytesIO()
    wb.save(buf)
    assert efficiencies(read("rig.xlsx", buf.getvalue())) == pytest.approx(EFFICIENCY, rel=1e-12)


@pytest.mark.parametrize("name", ["rig.csv", "rig.xlsx"])
@pytest.mark.parametrize("header", ["Efficiency", "Efficiency [%]", "Efficiency [-]"])
def test_per_cent_written_in_the_cells_is_read_whatever_the_header_says(name, header):
    table = rows(efficiency=lambda e: f"{100 * e:.6f}%")
    content = (csv if name.endswith(".csv") else workbook)(["Speed", "Flow [kg/s]", "PR", header], table)
    assert efficiencies(read(name, content)) == pytest.approx(EFFICIENCY, abs=1e-8)


def test_per_cent_cells_among_plain_fractions_are_fractions():
    # Excel writes a percentage cell '85.85%' and a General cell 0.8585 to CSV: both are 0.8585
    table = [r if k % 3 else r[:3] + [f"{100 * r[3]:.6f}%"] for k, r in enumerate(rows())]
    loaded = read("rig.csv", csv(["Speed", "Flow [kg/s]", "PR", "Efficiency"], table))
    assert efficiencies(loaded) == pytest.approx(EFFICIENCY, abs=1e-8)
    assert "upload_rows_skipped" not in codes(loaded)
    conversion = next(c for c in loaded.source["conversions"] if c["basis"] == "cells")
    assert conversion["from_unit"] == "%" and conversion["to_unit"] == "1" and conversion["factor"] == pytest.approx(0.01)


def test_a_unit_in_the_number_format_is_the_columns_unit():
    loaded = read("rig.xlsx", workbook(["Speed", "Flow", "Pressure", "Efficiency"], rows(speed=lambda s: 10_000 * s),
                                       ('0" rpm"', '0.00" kg/s"', '0.000 "bar"', None)))
    assert loaded.units.flow == "kg/s" and loaded.units.pressure == "bar"
    assert loaded.request.setting_units == ["rpm"]
    assert np.sort(np.concatenate([p.flow for p in loaded.internal.positions])) == pytest.approx(np.sort(FLOW))


def test_a_speed_formatted_as_a_percentage_is_per_cent():
    loaded = read("rig.xlsx", workbook(["Speed", "Flow [kg/s]", "PR", "Efficiency"], rows(), ("0%", None, None, None)))
    assert loaded.request.setting_units == ["%"]
    assert sorted({p.setting[0] for p in loaded.request.positions}) == pytest.approx([100 * p["setting"][0] for p in LINES])


@pytest.mark.parametrize("name", ["rig.csv", "rig.xlsx"])
def test_cells_in_another_unit_than_the_header_are_refused_naming_both(name):
    if name.endswith(".xlsx"):
        content = workbook(["Speed", "Flow [kg/s]", "PR", "Efficiency"], rows(), (None, '0.00" lb/s"', None, None))
    else:
        content = csv(["Speed", "Flow [kg/s]", "PR", "Efficiency"], rows(flow=lambda f: f"{f!r} lb/s"))
    with pytest.raises(InputRejected) as e:
        read(name, content)
    error = e.value.errors[0]
    assert error.loc == ("file", "row", 2, "flow")
    assert "'kg/s'" in error.msg and "'lb/s'" in error.msg and "Flow [kg/s]" in error.msg


def test_a_unit_in_some_cells_of_a_column_without_one_is_refused_naming_the_lines():
    table = [r if k % 3 else [r[0], f"{r[1]!r} kg/s"] + r[2:] for k, r in enumerate(rows())]
    with pytest.raises(InputRejected) as e:
        read("rig.csv", csv(["Speed", "Flow", "PR", "Efficiency"], table))
    assert e.value.errors[0].loc == ("file", "row", 3, "flow")
    assert "'kg/s'" in e.value.errors[0].msg and "header states no unit" in e.value.errors[0].msg


def test_an_abbreviated_header_with_its_dot_is_read():
    loaded = read("rig.csv", csv(["Rel. speed", "Flow [kg/s]", "PR", "Eff. (%)"], rows(efficiency=lambda e: 100 * e)))
    assert efficiencies(loaded) == pytest.approx(EFFICIENCY)


@pytest.mark.parametrize("number_format, expected", [
    ("0.00%", (1, "")), ('0.00" kg/s"', (0, "kg/s")), ('0.0 "bar"', (0, "bar")), ("0.0\\%", (0, "%")),
    ("0.00%;[Red]-0.00%", (1, "")), ("#,##0.00", (0, "")), ("[$-409]0.00", (0, "")), ("0.0_);(0.0)", (0, "")),
    ("General", (0, "")),
])
def test_number_formats_say_percentages_and_units(number_format, expected):
    assert format_unit(number_format) == expected


def test_a_pycycle_efficiency_map_in_per_cent_is_refused_naming_effmap():
    from pathlib import Path
    import re

    text = (Path(__file__).parent / "data" / "pycycle_fan_map.py").read_text()
    start = re.search(r"effMap\s*=\s*np\.array\(", text).end()
    end = text.index(")", start)
    per_cent = text[:start] + re.sub(r"\d+\.\d+", lambda m: repr(round(100 * float(m.group()), 4)),
                                     text[start:end]) + text[end:]
    with pytest.raises(InputRejected) as e:
        parse_upload(StoredInput.from_bytes("fan.py", per_cent.encode()), None)
    assert e.value.errors[0].loc == ("file", "effMap") and "per cent" in e.value.errors[0].msg


def test_rig_spellings_in_cells_are_read_as_their_headers_unit():
    # '1/min' begins with a digit, 'pct' is pint's picocarat: both are what rigs write for rpm and per cent
    table = rows(speed=lambda s: f"{10_000 * s:g} 1/min", efficiency=lambda e: f"{100 * e:.6f} pct")
    loaded = read("rig.csv", csv(["Speed [rpm]", "Flow [kg/s]", "PR", "Efficiency"], table))
    assert loaded.request.setting_units == ["rpm"]
    assert efficiencies(loaded) == pytest.approx(EFFICIENCY, abs=1e-8)


@pytest.mark.parametrize("header, cell, unit", [("IGV [deg]", "{:g}°", "deg"), ("IGV", "{:g} deg", "deg"),
                                                ("IGV", "{:g}°", "°")])
def test_angles_written_in_the_cells_are_the_settings_unit(header, cell, unit):
    angles = (-10.0, 0.0, 10.0)
    table = [[cell.format(a), r[0], r[1] * (1 + a / 100), r[2], r[3]] for a in angles for r in rows()]
    loaded = read("rig.csv", csv([header, "Speed", "Flow [kg/s]", "PR", "Efficiency"], table))
    assert loaded.request.setting_units[0] == unit
    assert sorted({p.setting[0] for p in loaded.request.positions}) == list(angles)


def test_radians_in_the_cells_of_a_degree_column_are_refused():
    table = [[f"{a} rad", *r] for a in (-0.1, 0.0, 0.1) for r in rows()]
    with pytest.raises(InputRejected) as e:
        read("rig.csv", csv(["IGV [deg]", "Speed", "Flow [kg/s]", "PR", "Efficiency"], table))
    assert "'rad'" in e.value.errors[0].msg and "IGV [deg]" in e.value.errors[0].msg


def test_a_long_cell_is_refused_as_no_number_without_the_unit_pattern_scanning_it():
    # 'number, a word, 200 000 blanks, a word': the unit pattern's lazy group before '\s*$' retried the blanks at
    # every extension (5 s of CPU for 40 KB); a cell longer than any number with its unit is no number
    from plantsolve.solvers.perfmap.cell_units import split_cell

    cell = "0.8 a" + " " * 200_000 + "b"
    assert split_cell(cell) == (cell, None)
    assert split_cell("  12.3 kg/s  ") == ("12.3", "kg/s")
    table = rows()
    text = "speed [rpm],flow [kg/s],pressure ratio,efficiency\n" + "\n".join(
        ",".join(str(v) for v in r) for r in table)
    text = text.replace(str(table[0][3]), cell, 1)
    request = parse_upload(StoredInput.from_bytes("map.csv", text.encode()), None)
    skipped = [w for w in request.upload_warnings if w.code == "upload_rows_skipped"]
    assert skipped and "line 2: efficiency" in skipped[0].message and "is not a number" in skipped[0].message
    assert len(skipped[0].message) < 500  # the cell is not repeated whole
