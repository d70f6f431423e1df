"""GasTurb / GSP map files (``.map``) as uploads: closed-form maps written in the published layout (wrapped and
one record a line), GSPy's sample maps (data/gasturb, Apache-2.0, see data/README.md), a turbine map refused
naming what it is, and the mistakes users make (cut, garbled, percent, another kind of file) refused naming the
line."""

from __future__ import annotations

from functools import cache
from pathlib import Path

import numpy as np
import pytest

from plantsolve.schemas.perfmap import PerfmapBetaQueryRequest
from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.perfmap.query import answer_beta_query
from plantsolve.solvers.perfmap.solve import solve
from plantsolve.solvers.perfmap.upload import parse_upload

GASTURB = Path(__file__).parent / "data" / "gasturb"

A = np.array([1.6, 2.2, 3.0, 4.0])  # PR = A_k - B Wc^2 on the line of speed k
B = 0.02
C_SURGE, C_CHOKE = 0.05, 0.01  # beta 1 and beta 0: PR - 1 = c Wc^2
SPEEDS = [0.6, 0.7, 0.8, 0.9]
BETA = np.linspace(0.0, 1.0, 11)


def closed_form_tables():
    """Flow, efficiency and pressure ratio at (speed, beta): the crossings of the speed lines with the beta
    parabolas PR - 1 = c Wc^2, c = c_choke + beta (c_surge - c_choke) (Smooth C's beta grid); the efficiency a
    parabola in flow."""
    c = C_CHOKE + BETA * (C_SURGE - C_CHOKE)
    W = np.array([np.sqrt((a - 1) / (B + c)) for a in A])
    P = np.array([a - B * w * w for a, w in zip(A, W)])
    u = (W - W[:, -1:]) / (W[:, :1] - W[:, -1:])  # 0 at surge, 1 at choke
    E = 0.9 - 0.2 * (u - 0.4) ** 2  # a parabola in flow on each line
    return W, E, P


def record(first: str, values, wrapped: bool) -> list[str]:
    """The published layout: the leading number and four values on a line, five a line after that."""
    cells = [f"{v:.10g}" for v in values]
    if not wrapped:
        return [" ".join([first, *cells])]
    return [" ".join([first, *cells[:4]])] + [" ".join(cells[i:i + 5]) for i in range(4, len(cells), 5)]


def write_map(W, E, P, speeds=SPEEDS, beta=BETA, wrapped=True, head="99    closed form compressor map",
              reynolds="Reynolds: RNI=0.1 f=1 RNI=1 f=1", choke=True) -> str:
    out = [head, reynolds] if reynolds else [head]
    key = f"{len(speeds) + 1}.{len(beta) + 1:03d}"
    for name, table in (("Mass Flow", W), ("Efficiency", E), ("Pressure Ratio", P)):
        out += [name, *record(key, beta, wrapped)]
        for s, row in zip(speeds, table):
            out += record(f"{s:g}", row, wrapped)
        out.append("")
    limits = [("Surge Line", W[:, -1], P[:, -1])] + ([("Choke Line", W[:, 0], P[:, 0])] if choke else [])
    for name, x, y in limits:
        out += [name, *record(f"2.{len(x) + 1:03d}", x, wrapped), *record("1.0", y, wrapped), ""]
    return "\n".join(out) + "\n"


def read(text: str | bytes, options: dict | None = None, name: str = "m.map"):
    data = text.encode() if isinstance(text, str) else text
    return parse_upload(StoredInput.from_bytes(name, data), {"map": False, **(options or {})})


def refused(text: str | bytes, options: dict | None = None, name: str = "m.map"):
    with pytest.raises(InputRejected) as e:
        read(text, options, name)
    return e.value.errors


def note(req, code: str):
    return next(w for w in req.upload_warnings if w.code == code)


@cache
def sample(name: str) -> str:
    return (GASTURB / name).read_text()


@cache
def solved_sample(name: str):
    req = read(sample(name))
    return req, solve(req).result


# ---------------------------------------------------------------- known answers: maps written from closed forms

def test_a_closed_form_map_reads_the_same_wrapped_or_one_record_a_line():
    W, E, P = closed_form_tables()
    wrapped, one_line = read(write_map(W, E, P)), read(write_map(W, E, P, wrapped=False))
    assert wrapped.positions == one_line.positions
    assert wrapped.setting_names == ["Nc"] and wrapped.setting_units == ["1"]
    assert wrapped.units.flow is None and wrapped.units.pressure == "1"
    for p, s, w, e, pr in zip(wrapped.positions, SPEEDS, W, E, P):
        assert p.setting == [s]
        assert p.flow == pytest.approx(w, rel=1e-9) and p.pressure == pytest.approx(pr, rel=1e-9)
        assert p.efficiency == pytest.approx(e, rel=1e-9)
    d = note(wrapped, "upload_settings").details
    assert d["format"] == "gasturb" and d["map_type"] == 99 and d["title"] == "closed form compressor map"
    assert d["beta"] == pytest.approx(BETA) and d["reynolds"]["RNI"] == [0.1, 1.0] and d["reynolds"]["f"] == [1, 1]
    assert d["surge_line"][0]["flow"] == pytest.approx(W[:, -1], rel=1e-9)
    assert d["choke_line"][0]["pressure"] == pytest.approx(P[:, 0], rel=1e-9)
    assert "relative corrected speed" in note(wrapped, "upload_settings").message
    assert note(wrapped, "upload_rline_not_needed").details["beta"] == pytest.approx(BETA)


def test_a_closed_form_map_fits_exactly_and_the_beta_grid_of_the_fit_is_the_files():
    """The speed lines are parabolas (fitted exactly) and the file's beta lines are Smooth C parabolas through
    (0, 1): with 11 parabolic beta lines the fitted map's (speed, beta) lookup returns the file's own table."""
    W, E, P = closed_form_tables()
    req = read(write_map(W, E, P), {"model": "parabola", "efficiency_model": "parabola",
                                   "beta_grid": {"lines": 11, "shape": "parabola"}})
    res = solve(req).result
    assert all(s.pressure_max_rel_error < 1e-9 for s in res.settings)
    for k, speed in enumerate(SPEEDS):
        for j in (0, 3, 10):
            q = PerfmapBetaQueryRequest.model_validate({"speed": speed, "beta": BETA[j]})
            a = answer_beta_query(res, q).points[0]
            assert (a.flow, a.pressure) == pytest.approx((W[k, j], P[k, j]), rel=1e-9)
            assert a.efficiency == pytest.approx(E[k, j], abs=1e-9)


def test_rows_in_any_order_line_ends_and_decimal_commas_read_alike():
    W, E, P = closed_form_tables()
    base = read(write_map(W, E, P))
    shuffled = read(write_map(W[::-1], E[::-1], P[::-1], speeds=SPEEDS[::-1]))
    assert sorted(shuffled.positions, key=lambda p: p.setting) == base.positions
    text = write_map(W, E, P)
    assert read(text.replace("\n", "\r\n")).positions == base.positions
    assert read(text.replace("\n", "\r")).positions == base.positions
    comma = "\n".join(line if line[:1].isalpha() else line.replace(".", ",") for line in text.split("\n"))
    assert read(comma).positions == base.positions


def test_the_flow_unit_comes_from_the_units_option_or_the_title_and_a_wrong_one_is_refused():
    W, E, P = closed_form_tables()
    text = write_map(W, E, P)
    req = read(text, {"units": {"flow": "kg/s"}})
    assert req.units.flow == "kg/s" and req.options.model_dump().get("units") is None
    assert note(req, "upload_settings").details["flow_unit_from"] == "options.units"
    assert solve(req).result.units.flow == "kg/s"
    titled = read(text.replace("99    closed form compressor map", "99    rig map; flow [lbm/s], pressure [-]"))
    assert titled.units.flow == "lbm/s" and note(titled, "upload_settings").details["flow_unit_from"] == "title"
    (err,) = refused(text, {"units": {"flow": "kg"}})
    assert err.loc == ("options", "units", "flow") and "not a unit of flow" in err.msg
    # a title unit that is no flow unit is refused naming the title, with or without a units option (with one, the
    # comparison of the two raised an error the upload did not expect: a 500)
    bogus = text.replace("99    closed form compressor map", "99    rig map; flow [bogusunit]")
    for options in (None, {"units": {"flow": "kg/s"}}):
        (err,) = refused(bogus, options)
        assert err.loc == ("file", "title") and "flow" in err.msg


def test_a_map_with_variable_geometry_has_the_setting_before_the_speed():
    """One set of tables per vane setting, each after a line naming it: two settings (VG angle, Nc), the second
    set's flows 10 % larger."""
    W, E, P = closed_form_tables()
    sets = [write_map(w, E, P, head="3    variable geometry compressor").split("\n") for w in (W, 1.1 * W)]
    head, first, second = "\n".join(sets[0][:2]), "\n".join(sets[0][2:]), "\n".join(sets[1][2:])
    req = read(f"{head}\nVG angle = -5 [deg]\n{first}VG angle = 5 [deg]\n{second}")
    assert req.setting_names == ["VG angle", "Nc"] and req.setting_units == ["deg", "1"]
    assert [p.setting for p in req.positions] == [[a, s] for a in (-5.0, 5.0) for s in SPEEDS]
    assert req.positions[5].flow == pytest.approx(1.1 * W[1], rel=1e-9)
    assert note(req, "upload_settings").details["map_type"] == 3
    assert len(solve(req).result.settings) == 8
    # without the setting lines the second set is a second Mass Flow table: refused naming it
    text = f"{head}\n{first}{second}"
    (err,) = refused(text)
    n = text.split("\n").index("Mass Flow", 3) + 1
    assert err.loc == ("file", "line", n) and "a second Mass Flow table" in err.msg


# ---------------------------------------------------------------- GSPy's sample maps (GSP users' maps)

@pytest.mark.parametrize("name, speeds, betas, kept", [("compmap.map", 14, 9, 12), ("bigfanc.map", 10, 15, 10),
                                                      ("bigfand.map", 10, 15, 10)])
def test_gspys_sample_maps_read_and_fit_every_line_within_1_percent_of_its_floor(name, speeds, betas, kept):
    req, res = solved_sample(name)
    d = note(req, "upload_settings").details
    assert d["map_type"] == 99 and len(d["beta"]) == betas and d["beta"][0] == 0.0 and d["beta"][-1] == 1.0
    assert d["reynolds"] == {"RNI": [0.1, 1.0], "f": [1.0, 1.0], "line": 2}
    assert len(req.positions) == kept and len(res.settings) == kept
    assert all(s.pressure_excess <= 0.01 for s in res.settings)
    assert d["surge_line"] and len(d["surge_line"][0]["flow"]) == len(d["surge_line"][0]["pressure"])
    assert speeds - kept == len((note(req, "upload_points_dropped").details["lines"]) if kept < speeds else [])


def test_compmap_values_and_its_choked_top_lines():
    """compmap.map: 14 speeds 0.45 ... 1.08; at 1.04 and 1.08 every beta point has the same flow (fully choked,
    vertical in the map): those two lines are left out and said so; the others read value for value."""
    req, res = solved_sample("compmap.map")
    first = req.positions[0]
    assert first.setting == [0.45] and first.flow[0] == 8.2 and first.flow[-1] == 4.4
    assert first.efficiency[:3] == [0.62, 0.64, 0.64] and first.pressure[0] == 0.9397
    dropped = note(req, "upload_points_dropped")
    assert [d["setting"] for d in dropped.details["lines"]] == [[1.04], [1.08]]
    assert [d["distinct_flows"] for d in dropped.details["lines"]] == [2, 1]
    surge = note(req, "upload_settings").details["surge_line"][0]
    assert len(surge["flow"]) == 14 and surge["flow"][0] == 5.37436 and surge["pressure"][0] == 1.60026
    assert "upload_points_dropped" in {w.code for w in res.report.warnings}


def test_bigfand_is_bigfanc_at_other_speed_values():
    c, d = (read(sample(n)) for n in ("bigfanc.map", "bigfand.map"))
    assert [p.flow for p in c.positions] == [p.flow for p in d.positions]
    assert [p.setting[0] for p in d.positions][:3] == [0.2, 0.39, 0.48]
    assert c.positions[0].flow[:4] == [26.4, 24.0, 21.0, 19.4]  # the first record's values, wrapped after four


def test_a_turbine_map_is_refused_naming_what_it_is():
    (err,) = refused(sample("turbimap.map"))
    assert err.loc == ("file", "line", 3) and "turbine map" in err.msg and "Min Pressure Ratio" in err.msg


# ---------------------------------------------------------------- the mistakes users make

def _lines_of(name: str) -> list[str]:
    return sample(name).split("\n")


def _cut(name: str, line: int, keep: int | None = None) -> str:
    """The file cut inside line ``line`` (1-based), ``keep`` characters of it kept."""
    lines = _lines_of(name)
    last = lines[line - 1]
    return "\n".join(lines[:line - 1] + [last[:keep if keep is not None else len(last) // 2]])


def test_a_file_cut_inside_a_speed_table_is_refused_as_truncated_naming_the_table():
    for line, table, start in ((10, "Mass Flow", 3), (40, "Pressure Ratio", 37)):
        (err,) = refused(_cut("compmap.map", line))
        assert err.type == "truncated_file" and err.loc == ("file", "line", start) and table in err.msg
    (err,) = refused(_cut("bigfanc.map", 20))  # inside a wrapped record
    assert err.type == "truncated_file" and "Mass Flow" in err.msg


def test_a_file_cut_inside_the_surge_line_is_read_with_a_truncated_file_warning():
    lines = _lines_of("bigfanc.map")
    n = lines.index("Surge Line") + 1
    req = read("\n".join(lines[:n + 2]))
    w = note(req, "truncated_file")
    assert w.details["line"] == n and w.details["table"] == "Surge Line"
    assert note(req, "upload_settings").details["surge_line"] is None and len(req.positions) == 10


@pytest.mark.parametrize("edit, line, words", [
    (lambda ls: ls.__setitem__(5, ls[5].replace("0.50000", "0.5O000")), 6, "is not a number"),
    (lambda ls: ls.__setitem__(3, ls[3].replace("15.01000", "15.01234")), 4, "no table key"),
    (lambda ls: ls.__setitem__(4, ls[4] + "  4.1"), 5, "more than"),
    (lambda ls: ls.__setitem__(9, ""), 10, "ends after"),
    (lambda ls: ls.__setitem__(1, "Reynolds: RNI=abc"), 2, "Reynolds"),
    (lambda ls: ls.__setitem__(3, ls[3].replace("15.01000", "99999.999")), 4, "at most"),
    (lambda ls: ls.__setitem__(21, ls[21].replace("0.45000", "0.47000", 1)), 22, "differ from the Mass Flow"),
    (lambda ls: ls.__setitem__(6, ls[6].replace("0.60000", "0.50000", 1)), 7, "appears twice"),
    (lambda ls: ls.insert(2, "some stray note"), 3, "neither a table keyword"),
])
def test_garbled_maps_are_refused_naming_the_line(edit, line, words):
    lines = _lines_of("compmap.map")
    edit(lines)
    (err,) = refused("\n".join(lines))
    assert err.loc == ("file", "line", line) and words in err.msg and f"line {line}" in err.msg


def test_efficiency_in_percent_is_refused_naming_the_row():
    lines = _lines_of("compmap.map")
    k = lines.index("Efficiency")
    for i in range(k + 2, k + 16):
        cells = lines[i].split()
        lines[i] = " ".join([cells[0]] + [f"{float(c) * 100:.3f}" for c in cells[1:]])
    (err,) = refused("\n".join(lines))
    assert err.loc == ("file", "row", k + 3, "efficiency") and "percent" in err.msg


@pytest.mark.parametrize("text, words", [
    ("speed,flow,pressure,efficiency\n0.9,10,2,0.8\n", "upload it as .csv"),
    ("import numpy as np\nfrom pycycle.maps.map_data import MapData\nM = MapData()\n", "upload it as .py"),
    ('{"positions": []}', "upload a JSON request as .json"),
    ("", "none of its tables"),
    ("99 title only\n", "none of its tables"),
])
def test_a_file_of_another_kind_is_refused_saying_what_it_looks_like(text, words):
    (err,) = refused(text)
    assert err.loc == ("file",) and words in err.msg


def test_binary_content_is_refused():
    (err,) = refused(b"\x00\x01\x02GasTurb")
    assert err.loc == ("file",) and "binary" in err.msg


def test_a_table_a_compressor_map_does_not_need_is_read_and_left_out():
    W, E, P = closed_form_tables()
    text = write_map(W, E, P)
    extra = "Temperature Ratio\n" + "\n".join(record("3.003", [0.0, 1.0], False) + record("0.5", [1, 2], False)
                                              + record("1.0", [3, 4], False)) + "\n\n"
    req = read(text + extra)
    assert req.positions == read(text).positions
    assert note(req, "upload_tables_ignored").details["tables"][0]["table"] == "Temperature Ratio"
    # its values garbled: refused naming the line
    (err,) = refused(text + extra.replace(" 1 2", " 1 2O"))
    assert err.loc == ("file", "line", len(text.split("\n")) + 2) and "is not a number" in err.msg
    # no key under it: a stray text line, refused naming it
    (err,) = refused(text + extra.replace("3.003", "3.0O3"))
    assert err.loc == ("file", "line", len(text.split("\n"))) and "neither a table keyword" in err.msg


def test_a_map_without_surge_line_is_read_and_says_so():
    W, E, P = closed_form_tables()
    text = write_map(W, E, P, choke=False)
    text = text[:text.index("Surge Line")]
    req = read(text)
    assert note(req, "upload_no_surge_line") and len(req.positions) == 4


def test_maps_through_the_service_a_sample_map_runs_and_a_turbine_map_is_a_422(tmp_path):
    from fastapi.testclient import TestClient

    from plantsolve.app.main import create_app
    from tests.conftest import service_settings, wait_for

    with TestClient(create_app(service_settings(tmp_path))) as client:
        ok = client.post("/v1/perfmap/jobs", files={"file": ("compmap.map", sample("compmap.map").encode(),
                                                            "application/octet-stream")},
                         data={"options": '{"map": false, "units": {"flow": "kg/s"}}'})
        assert ok.status_code == 202, ok.text
        job = wait_for(client, ok.json()["id"], timeout=180)
        assert job["status"] == "succeeded", job
        result = client.get(f"/v1/jobs/{job['id']}/result").json()
        assert len(result["settings"]) == 12 and result["units"]["flow"] == "kg/s"
        bad = client.post("/v1/perfmap/jobs", files={"file": ("turbimap.map", sample("turbimap.map").encode(),
                                                             "application/octet-stream")})
        assert bad.status_code == 422 and bad.headers["content-type"] == "application/problem+json"
        assert ["file", "line", 3] in [e["loc"] for e in bad.json()["errors"]]


def test_keyword_lines_with_a_unit_comments_above_the_header_and_limit_lines_of_two_rows():
    W, E, P = closed_form_tables()
    text = write_map(W, E, P)
    req = read("# exported by a rig tool\n" + text.replace("Mass Flow\n", "Mass Flow [kg/s]\n", 1)
               .replace("Efficiency\n", "Efficiency: isentropic\n", 1))
    assert req.positions == read(text).positions and req.units.flow == "kg/s"
    assert note(req, "upload_settings").details["flow_unit_from"] == "Mass Flow table's line"
    (err,) = refused(text.replace("Mass Flow\n", "Mass Flow [kg]\n", 1))
    assert err.loc == ("file", "Mass Flow") and "not a unit of flow" in err.msg
    lines = text.split("\n")
    k = lines.index("Surge Line")
    lines[k + 1] = lines[k + 1].replace("2.005", "3.005", 1)
    lines.insert(k + 3, lines[k + 2])  # a second row of pressure ratios, as the key says
    (err,) = refused("\n".join(lines))
    assert err.loc == ("file", "line", k + 2) and "2-row table" in err.msg


def test_speeds_in_percent_are_kept_and_warned_about():
    W, E, P = closed_form_tables()
    req = read(write_map(W, E, P, speeds=[60, 70, 80, 90]))
    w = note(req, "implausible_speed")
    assert w.details == {"value": 90.0, "range": [0.0, 3.0]} and "percent or rpm" in w.message
    assert req.setting_units == [""] and [p.setting for p in req.positions] == [[60.0], [70.0], [80.0], [90.0]]
    assert solve(req).result.units.settings == [None]


def test_a_file_ending_before_its_pressure_ratio_table_is_truncated_and_one_geometry_is_a_note():
    W, E, P = closed_form_tables()
    text = write_map(W, E, P)
    (err,) = refused(text[:text.index("Pressure Ratio")])
    assert err.type == "truncated_file" and err.loc == ("file", "Pressure Ratio") and "cut?" in err.msg
    req = read(text.replace("Mass Flow\n", "IGV = 10 [deg]\nMass Flow\n", 1))
    assert req.setting_names == ["Nc"] and note(req, "upload_geometry_setting").details["value"] == 10.0


def test_one_table_with_its_speed_rows_in_another_order_is_matched_by_speed():
    """The Efficiency table lists the speeds in reverse (pasted from another tool): each row is keyed by its speed,
    so the rows are matched to the Mass Flow table's and the map reads as the ordered one, with a note naming the
    table; rows of other speeds are still refused."""
    W, E, P = closed_form_tables()
    base = read(write_map(W, E, P))
    lines = write_map(W, E, P).split("\n")
    start = lines.index("Efficiency")
    rows = [lines[start + 4 + 3 * k:start + 4 + 3 * (k + 1)] for k in range(4)]  # 3 lines a record of 11 values
    assert all(r[0].split()[0] == f"{s:g}" for r, s in zip(rows, SPEEDS))
    shuffled = lines[:start + 4] + [ln for r in rows[::-1] for ln in r] + lines[start + 16:]
    req = read("\n".join(shuffled))
    assert req.positions == base.positions
    n = note(req, "upload_rows_reordered")
    assert n.details["table"] == "Efficiency" and n.details["line"] == start + 1
    other = "\n".join(shuffled).replace(f"\n{SPEEDS[0]:g} ", "\n0.65 ", 1)
    (err,) = refused(other)
    assert "differ from the Mass Flow" in err.msg


def test_a_surge_line_contradicting_the_speed_tables_is_said_naming_its_line():
    """A Surge Line in lbm/s under speed tables in kg/s (every flow 2.2 times too large): read, and a note names
    the table, its line and the quantity; the result's surge line is the fitted lines' ends either way."""
    W, E, P = closed_form_tables()
    text = write_map(W, E, P)
    lines = text.split("\n")
    n = lines.index("Surge Line") + 1
    flows = [f"{v:.10g}" for v in W[:, -1] * 2.20462]
    lines[n] = " ".join([lines[n].split()[0], *flows])
    req = read("\n".join(lines))
    (w,) = [w for w in req.upload_warnings if w.code == "upload_limit_line_off_map"]
    assert w.details["table"] == "Surge Line" and w.details["line"] == n and w.details["quantity"] == "flow"
    assert f"line {n}" in w.message and "another unit" in w.message
    assert "upload_limit_line_off_map" not in {x.code for x in read(text).upload_warnings}
    res = solve(req).result
    assert sorted(p.flow for p in res.surge_line) == pytest.approx(sorted(W[:, -1]), rel=1e-6)


def test_a_file_cut_at_a_line_end_inside_a_wrapped_record_is_truncated():
    """Cut where a line ends (the file then looks whole): bigfanc's records are wrapped, so a record missing its
    continuation lines is a cut, named as such."""
    lines = _lines_of("bigfanc.map")
    for keep in (5, 6, 20):
        (err,) = refused("\n".join(lines[:keep]) + "\n")
        assert err.type == "truncated_file" and "Mass Flow" in err.msg and err.loc == ("file", "line", 3)


def test_more_beta_lines_than_gsp_reads_are_refused_naming_the_field():
    """GSP reads at most 40 values a table row: 41 beta lines are refused (not capped), naming the option."""
    (err,) = refused(sample("compmap.map"), {"beta_grid": {"lines": 41}})
    assert err.loc == ("options", "beta_grid", "lines") and "GSP" in err.msg and "40" in err.msg
    assert len(read(sample("compmap.map"), {"beta_grid": {"lines": 40}}).options.beta_grid.model_dump()) == 3


def test_more_speed_lines_in_a_file_than_gsp_reads_in_a_limit_line_table_are_warned_about():
    """45 speed lines: the GasTurb file's Surge and Choke Line tables hold 45 flows, beyond GSP's 40; said, and the
    file still written (GasTurb and GSPy read it)."""
    from plantsolve.schemas.perfmap import PerfmapRequest
    from plantsolve.solvers.perfmap.cycle_exports import gasturb_tables

    speeds = np.linspace(0.5, 1.0, 45)
    positions = []
    for k, speed in enumerate(speeds):
        a = 1.5 + 2.5 * k / 44
        x = np.linspace(np.sqrt((a - 1) / (B + C_SURGE)), np.sqrt((a - 1) / (B + C_CHOKE)), 5)
        positions.append({"setting": [float(speed)], "flow": x.tolist(), "pressure": (a - B * x * x).tolist(),
                          "efficiency": (0.9 - 0.01 * (x - x.mean()) ** 2).tolist()})
    res = solve(PerfmapRequest.model_validate({"setting_names": ["Nc"], "positions": positions, "options": {
        "map": False, "model": "parabola", "efficiency_model": "parabola", "beta_grid": {"lines": 5}}})).result
    (w,) = [w for w in res.report.warnings if w.code == "gasturb_beyond_gsp_limits"]
    assert w.details["speed_lines"] == 45 and w.details["limit"] == 40 and "GSP" in w.message
    (text,) = gasturb_tables(res).values()
    assert "\n       46.006" in text.decode() and "\n        2.046" in text.decode()
