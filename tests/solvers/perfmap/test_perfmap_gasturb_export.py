"""GasTurb map text out (``map_gasturb*.map``) in the layout of GasTurb's own maps: read at the published
positions (key and four values on a record's first line, five a line after, every speed starting a line, a blank
line closing each table), read back by the project's ``.map`` reader, and round trips in -> fit -> out -> in on a
closed-form map and on GSPy's sample maps (data/gasturb)."""

from __future__ import annotations

from functools import cache
from pathlib import Path

import numpy as np
import pytest

from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.perfmap.cycle_exports import gasturb_tables
from plantsolve.solvers.perfmap.solve import solve
from plantsolve.solvers.perfmap.upload import parse_upload
from plantsolve.solvers.perfmap.validation import loaded
from tests.support.perfmap_fits import fits_agree, pressure_differences

GASTURB = Path(__file__).parent / "data" / "gasturb"
TABLES = ("Mass Flow", "Efficiency", "Pressure Ratio", "Surge Line", "Choke Line")


def read_at_published_positions(text: str) -> dict:
    """A reader that takes the published positions and nothing else: after a table's title, the key
    rows + columns / 1000 and the first four arguments on one line, the other arguments five a line; each row a
    parameter and four values on a new line, five a line after; the table closed by a blank line. Any other count
    on a line fails."""
    lines = text.split("\n")
    assert lines[0].split()[0] == "99" and lines[1].startswith("Reynolds: RNI=")

    def record(i: int, n: int) -> tuple[list[float], int]:
        first = lines[i].split()
        assert len(first) == 1 + min(4, n), (i + 1, lines[i])
        values = [float(c) for c in first]
        i += 1
        while len(values) < n + 1:
            cells = lines[i].split()
            assert len(cells) == min(5, n + 1 - len(values)), (i + 1, lines[i])
            values += [float(c) for c in cells]
            i += 1
        return values, i

    out = {}
    i = 2
    while i < len(lines) and lines[i]:
        title = lines[i]
        assert title in TABLES and title not in out
        key = float(lines[i + 1].split()[0])
        rows, cols = int(key) - 1, round((key - int(key)) * 1000) - 1
        head, i = record(i + 1, cols)
        params, values = [], []
        for _ in range(rows):
            row, i = record(i, cols)
            params.append(row[0])
            values.append(row[1:])
        assert lines[i] == ""  # a blank line closes the table
        i += 1
        out[title] = (np.array(head[1:]), np.array(params), np.array(values))
    assert i >= len(lines) - 1
    return out


def read_map(data: bytes, options: dict | None = None):
    return parse_upload(StoredInput.from_bytes("again.map", data), {"map": False, **(options or {})})


def sample_request(name: str, lines: int = 21, spacing: str = "adaptive"):
    return parse_upload(StoredInput.from_bytes(name, (GASTURB / name).read_bytes()),
                        {"map": False, "beta_grid": {"lines": lines, "spacing": spacing}})


@cache
def fitted(name: str, lines: int = 21, spacing: str = "adaptive"):
    return solve(sample_request(name, lines, spacing)).result


def only_table(result) -> bytes:
    (data,) = gasturb_tables(result).values()
    return data


@pytest.mark.parametrize("name", ["compmap.map", "bigfanc.map"])
def test_the_export_has_gasturbs_layout_and_holds_the_fitted_beta_map(name):
    res = fitted(name)
    text = only_table(res).decode()
    tables = read_at_published_positions(text)
    b = res.beta_map
    speeds = [line.setting[-1] for line in b.lines]
    for title, quantity in (("Mass Flow", "flow"), ("Efficiency", "efficiency"), ("Pressure Ratio", "pressure")):
        beta, params, values = tables[title]
        assert beta == pytest.approx(b.beta, abs=5e-8) and params == pytest.approx(speeds, rel=5e-7)
        assert values == pytest.approx(np.array([getattr(line, quantity) for line in b.lines]), rel=5e-7)
    flows, _, pressures = tables["Surge Line"]
    surge = sorted((p.flow, p.pressure) for p in res.surge_line)
    assert np.column_stack([flows, pressures[0]]) == pytest.approx(np.array(surge), rel=5e-7)
    # what GSP's reader relies on: the title holds no table keyword, the tables come in GasTurb's order
    assert not any(t.upper() in text.split("\n")[0].upper() for t in TABLES + ("Reynolds",))
    order = [text.index(f"\n{t}\n") for t in TABLES]
    assert order == sorted(order)


def test_the_exports_one_line_records_are_gone():
    """Before: every row on one line (22 numbers for a 21-line grid). Now no line holds more than five."""
    text = only_table(fitted("compmap.map")).decode()
    assert max(len(line.split()) for line in text.split("\n")[2:]) == 5


@pytest.mark.parametrize("name", ["compmap.map", "bigfanc.map"])
def test_the_project_reader_reads_the_export_back_as_the_fitted_beta_map(name):
    res = fitted(name)
    req = read_map(only_table(res))
    assert req.setting_names == ["Nc"] and len(req.positions) == len(res.beta_map.lines)
    for p, line in zip(req.positions, res.beta_map.lines):
        assert p.setting == pytest.approx(line.setting, rel=5e-7)
        assert p.flow == pytest.approx(line.flow, rel=5e-7) and p.pressure == pytest.approx(line.pressure, rel=5e-7)
        assert p.efficiency == pytest.approx(line.efficiency, rel=5e-7)
    surge = next(w for w in req.upload_warnings if w.code == "upload_settings").details["surge_line"][0]
    assert sorted(surge["flow"]) == pytest.approx(sorted(p.flow for p in res.surge_line), rel=5e-7)


def test_a_stated_flow_unit_survives_the_round_trip_through_the_title():
    req = parse_upload(StoredInput.from_bytes("c.map", (GASTURB / "compmap.map").read_bytes()),
                       {"map": False, "units": {"flow": "kg/s"}})
    res = solve(req).result
    assert res.units.flow == "kg/s"
    again = read_map(only_table(res))
    assert again.units.flow == "kg/s" and again.units.pressure == "1"


def _closed_form_map() -> bytes:
    """Speed lines PR = A - 0.02 Wc^2 between the beta parabolas PR - 1 = 0.05 Wc^2 (beta 1) and 0.01 Wc^2
    (beta 0), 9 beta values, efficiency a parabola in flow; written in the published layout."""
    beta = np.linspace(0, 1, 9)
    c = 0.01 + beta * 0.04
    rows = {"Mass Flow": [], "Efficiency": [], "Pressure Ratio": []}
    speeds = [0.6, 0.7, 0.8, 0.9]
    for a in (1.6, 2.2, 3.0, 4.0):
        w = np.sqrt((a - 1) / (0.02 + c))
        u = (w - w[-1]) / (w[0] - w[-1])
        rows["Mass Flow"].append(w)
        rows["Pressure Ratio"].append(a - 0.02 * w * w)
        rows["Efficiency"].append(0.9 - 0.2 * (u - 0.4) ** 2)

    def rec(first, values):
        cells = [f"{v:.12g}" for v in values]
        return [" ".join([first] + cells[:4])] + [" ".join(cells[i:i + 5]) for i in range(4, len(cells), 5)]

    out = ["99 closed form", "Reynolds: RNI=0.1 f=1 RNI=1 f=1"]
    for name, table in rows.items():
        out += [name] + rec("5.010", beta)
        for s, row in zip(speeds, table):
            out += rec(f"{s:g}", row)
        out.append("")
    w, p = np.array(rows["Mass Flow"])[:, -1], np.array(rows["Pressure Ratio"])[:, -1]
    out += ["Surge Line"] + rec("2.005", w) + rec("1.0", p) + [""]
    return ("\n".join(out) + "\n").encode()


def test_round_trip_of_a_closed_form_map_is_exact_to_the_printed_digits():
    """in -> fit (exact: parabolas) -> out -> in -> fit: the same speed lines within 1e-6 (the export prints ten
    digits), far inside the fits' stated error plus that."""
    options = {"map": False, "model": "parabola", "efficiency_model": "parabola"}
    first = solve(parse_upload(StoredInput.from_bytes("cf.map", _closed_form_map()), options)).result
    assert max(s.pressure_max_rel_error for s in first.settings) < 1e-9
    again = solve(parse_upload(StoredInput.from_bytes("cf2.map", only_table(first)), options)).result
    p_all, _, e_all = fits_agree(first, again, rel=1e-6)
    assert p_all < 1e-6 and e_all < 1e-6
    assert max(s.pressure_max_rel_error for s in again.settings) < 1e-6


@pytest.mark.parametrize("name", ["compmap.map", "bigfanc.map"])
@pytest.mark.parametrize("lines, spacing", [(21, "adaptive"), (40, "adaptive"), (21, "even")])
def test_round_trip_of_gspys_sample_maps_is_within_the_error_the_result_states(name, lines, spacing):
    """in -> fit -> out -> in. At every measured point of the file the map read back, read linearly between its beta
    nodes as cycle codes read it, departs from the file's pressure ratio by at most what the result states: the
    setting's fit error plus the line's table error (ten printed digits aside). Fitted again, each line agrees
    with the first fit within its table error plus the refit's own stated error; efficiency within 1e-5."""
    res = fitted(name, lines, spacing)
    again_req = read_map(only_table(res))
    read_back = {tuple(p.setting): p for p in again_req.positions}
    fits = {tuple(s.setting): s for s in res.settings}
    tables = {tuple(line.setting): line for line in res.beta_map.lines}
    for s in loaded(sample_request(name, lines, spacing)).settings:
        p = read_back[s.values]
        order = np.argsort(p.flow)
        table = np.interp(s.x, np.array(p.flow)[order], np.array(p.pressure)[order])
        stated = fits[s.values].pressure_max_rel_error + tables[s.values].table_pressure_max_rel_error
        assert np.max(np.abs(table - s.y) / s.y) <= stated + 2e-6, s.values
    again = solve(again_req).result
    refit = {tuple(s.setting): s.pressure_max_rel_error for s in again.settings}
    for values, difference in pressure_differences(res, again).items():
        assert difference <= tables[values].table_pressure_max_rel_error + refit[values] + 1e-6, values
    assert fits_agree(res, again, rel=1e-6)[2] <= 1e-5


@pytest.mark.parametrize("name", ["compmap.map", "bigfanc.map"])
def test_the_adaptive_spacing_brings_the_round_trip_within_the_fits_stated_error(name):
    """Before: 21 evenly spaced beta lines left the steep choke ends between nodes, and the map read back and
    fitted again missed the first fit by more than the fit misses the data (compmap 2.1 %, bigfanc 3.1 %). The
    adaptive spacing states a table error below the fit's and the round trip lies within the fit's stated error."""
    even, adaptive = fitted(name, 21, "even"), fitted(name, 21, "adaptive")
    fit_error = max(s.pressure_max_rel_error for s in adaptive.settings)
    assert fit_error == max(s.pressure_max_rel_error for s in even.settings)
    assert even.beta_map.table_pressure_max_rel_error > fit_error > adaptive.beta_map.table_pressure_max_rel_error
    for res, within in ((even, False), (adaptive, True)):
        again = solve(read_map(only_table(res))).result
        assert (max(pressure_differences(res, again).values()) <= fit_error) is within
