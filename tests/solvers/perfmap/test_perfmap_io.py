"""check_input, parse_upload, render_artifacts and the schema's own checks."""

from __future__ import annotations

import copy
import json

import numpy as np
import pytest
from pydantic import ValidationError

from plantsolve.schemas.perfmap import PerfmapQueryRequest, PerfmapRequest
from plantsolve.solvers.base import InputRejected, Solved, StoredInput
from plantsolve.solvers.perfmap import SPEC, __version__
from plantsolve.solvers.perfmap.artifacts import render_artifacts
from plantsolve.solvers.perfmap.solve import solve
from plantsolve.solvers.perfmap.upload import parse_upload
from plantsolve.solvers.perfmap.validation import check_input
from plantsolve.solvers.perfmap.synthetic import request_body


def _body(**opts):
    return request_body(n_theta=2, n_phi=3, options=opts)


def _rejected_locs(body) -> list[tuple]:
    with pytest.raises(InputRejected) as exc:
        check_input(PerfmapRequest.model_validate(body))
    return [e.loc for e in exc.value.errors]


def test_contract_constants():
    assert SPEC.upload_extensions == (".csv", ".xlsx", ".json", ".py", ".map")
    assert SPEC.soft_time_limit < SPEC.time_limit
    assert isinstance(__version__, str) and SPEC.version == __version__


def test_valid_input_passes():
    check_input(PerfmapRequest.model_validate(_body()))


def test_fewer_than_three_points_rejected_by_schema():
    body = _body()
    for k in ("flow", "pressure", "efficiency"):
        body["positions"][1][k] = body["positions"][1][k][:2]
    with pytest.raises(ValidationError) as exc:
        PerfmapRequest.model_validate(body)
    assert exc.value.errors()[0]["loc"][:2] == ("positions", 1)


def test_fewer_than_three_distinct_points_rejected():
    body = _body()
    p = body["positions"][2]
    p["flow"] = [p["flow"][0]] * 2 + [p["flow"][1]]
    p["pressure"] = [p["pressure"][0]] * 2 + [p["pressure"][1]]
    p["efficiency"] = [p["efficiency"][0]] * 2 + [p["efficiency"][1]]
    assert _rejected_locs(body) == [("positions", 2, "flow")]


def test_repeated_flow_with_different_values_is_averaged_and_reported():
    body = _body(map=False)
    p = body["positions"][4]
    p["flow"][3] = p["flow"][2]
    res = solve(PerfmapRequest.model_validate(body)).result
    warn = next(w for w in res.report.warnings if w.code == "repeated_flows_averaged")
    assert warn.details["position"] == 4


def test_unsorted_and_duplicated_points_are_sorted_and_merged():
    body = _body(map=False)
    p = body["positions"][0]
    order = [3, 0, 5, 1, 4, 2]
    for k in ("flow", "pressure", "efficiency"):
        p[k] = [p[k][i] for i in order] + [p[k][0]]
    res = solve(PerfmapRequest.model_validate(body)).result
    ref = solve(PerfmapRequest.model_validate(_body(map=False))).result
    assert np.allclose(res.settings[0].pressure_coefficients, ref.settings[0].pressure_coefficients)
    assert any(w.code == "duplicate_points_merged" for w in res.report.warnings)


def test_length_mismatch_rejected():
    body = _body()
    body["positions"][0]["efficiency"].append(0.5)
    assert _rejected_locs(body) == [("positions", 0, "efficiency")]


def test_too_few_settings_for_a_map_but_envelope_possible():
    body = _body(map=True)  # an explicitly requested map must be possible: 422
    body["positions"] = body["positions"][:1]
    assert _rejected_locs(body) == [("positions",)]
    for flag, code in ((False, "map_skipped"), (None, "map_not_possible")):
        body["options"]["map"] = flag
        res = solve(PerfmapRequest.model_validate(body)).result
        assert res.map is None and len(res.envelopes) == 1 and res.triangles == []  # one theta
        # one speed line: its GasTurb export is one GSPy cannot load (it needs four), pyCycle takes none (it needs
        # two): the report says both
        assert [w.code for w in res.report.warnings] == ["gasturb_below_gspy_minimum", "pycycle_export_not_possible",
                                                         code]


def test_settings_on_one_line_give_the_one_parameter_map():
    # a single theta with several phi (a common rig layout, or speed lines): envelope and a map between
    # neighbouring lines
    body = request_body(n_theta=1, n_phi=5, options={"map": True})
    req = PerfmapRequest.model_validate(body)
    check_input(req)
    res = solve(req).result
    assert res.map is not None and res.map.reachable_fraction > 0.2 and len(res.envelopes) == 1
    assert all(j == k for _, j, k in res.triangles) and len(res.triangles) == 4
    env = res.envelopes[0]
    assert all(p is not None for p in env.pressure) and min(env.phi) >= 0
    assert "one_parameter_map" in [w.code for w in res.report.warnings]


def test_duplicate_setting_rejected():
    body = _body()
    body["positions"].append(copy.deepcopy(body["positions"][0]))
    assert _rejected_locs(body) == [("positions", 6)]


def test_nan_and_bad_options_rejected_by_schema():
    body = _body()
    body["positions"][0]["pressure"][0] = float("nan")
    with pytest.raises(ValidationError):
        PerfmapRequest.model_validate(body)
    for bad in ({"grid": [1, 64]}, {"model": "quartic"}, {"fit": "l1"}, {"unknown": 1}):
        with pytest.raises(ValidationError):
            PerfmapRequest.model_validate(_body(**bad))


def test_non_positive_pressure_rejected():
    body = _body()
    body["positions"][3]["pressure"][0] = -1.0
    assert _rejected_locs(body) == [("positions", 3, "pressure", 0)]


def test_query_request_one_or_many():
    one = PerfmapQueryRequest.model_validate({"flow": 1.0, "pressure": 2.0})
    many = PerfmapQueryRequest.model_validate({"points": [{"flow": 1.0, "pressure": 2.0}] * 3})
    assert len(one.points) == 1 and len(many.points) == 3
    with pytest.raises(ValidationError):
        PerfmapQueryRequest.model_validate({"points": []})


def test_parse_csv_round_trip_and_options(n3_csv):
    req = parse_upload(StoredInput.from_bytes("MAP.CSV", n3_csv), {"model": "cubic", "grid": [20, 10]})
    assert len(req.positions) == 18
    assert req.options.model == "cubic" and req.options.grid == [20, 10]
    first = req.positions[0]
    assert (first.theta, first.phi) == (0.0, 0.5) and len(first.flow) == 7
    assert first.flow[0] == pytest.approx(1104.338)


def test_parse_csv_semicolon_and_column_order():
    text = "phi;Theta;efficiency;pressure;flow\n" + "\n".join(
        f"{ph};{th};0.8;{2 - 0.1 * i};{i + 1}" for th in (0, 1) for ph in (0, 1) for i in range(4))
    req = parse_upload(StoredInput.from_bytes("m.csv", text.encode()), None)
    assert len(req.positions) == 4
    assert req.positions[1].phi == 1 and req.positions[1].flow == [1, 2, 3, 4]


def test_parse_json_file_with_form_options_joined_and_a_contradiction_refused():
    body = _body(grid=[30, 30])
    req = parse_upload(StoredInput.from_bytes("x.json", json.dumps(body).encode()), {"fit": "minimax"})
    assert req.options.grid == [30, 30] and req.options.fit == "minimax" and req.options.model == "cubic"
    with pytest.raises(InputRejected) as refused:
        parse_upload(StoredInput.from_bytes("x.json", json.dumps(body).encode()), {"grid": [12, 11]})
    (error,) = refused.value.errors
    assert error.loc == ("options", "grid") and "file.options.grid" in error.msg


@pytest.mark.parametrize("name,content,needle", [
    ("m.csv", b"", "empty"),
    ("m.csv", b"theta,phi,flow\n1,2,3\n", "missing"),
    ("m.csv", b"theta,phi,flow,pressure,efficiency\n1,2,x,4,5\n", "line 2"),
    ("m.csv", b"theta,phi,flow,pressure,efficiency\n1,2,nan,4,5\n", "NaN"),
    ("m.json", b"{not json", "invalid JSON"),
    ("m.json", b'{"positions": 3}', "positions"),
    ("m.csv", b"\xff\xfe\x00", "UTF-16"),
])
def test_bad_uploads_name_the_file(name, content, needle):
    with pytest.raises(InputRejected) as exc:
        parse_upload(StoredInput.from_bytes(name, content), None)
    assert all(e.loc[0] == "file" for e in exc.value.errors)
    assert needle in str(exc.value)


def test_render_artifacts(synthetic_request, synthetic_result):
    before = synthetic_result.model_dump_json()
    req_before = synthetic_request.model_dump_json()
    arts = render_artifacts(synthetic_request, Solved(synthetic_result))
    names = [a.name for a in arts]
    assert sorted(names) == sorted([f"{s}.{e}" for s in ("characteristics", "envelopes", "map")
                                    for e in ("png", "svg")] + ["curves.csv", "map.csv", "map_pycycle.py", "map_beta.csv"]
                                   + [f"map_gasturb_theta{v:g}.map" for v in (0, 15, 30)])
    for a in arts:
        if a.name == "map_beta.csv":
            assert a.media_type == "text/csv" and b"\ntheta,phi,beta [-]," in a.data
        elif a.name.endswith(".csv"):
            assert a.media_type == "text/csv" and a.data.startswith(b"theta,phi,") or a.data.startswith(b"flow")
        elif a.name.endswith(".png"):
            assert a.media_type == "image/png" and a.data[:8] == b"\x89PNG\r\n\x1a\n"
        elif a.name.endswith(".py"):
            assert a.media_type == "text/x-python" and b"ExportMap.WcMap = np.array(" in a.data
        elif a.name.endswith(".map"):
            assert a.media_type.startswith("text/plain") and a.data.startswith(b"99 ") and b"\nSurge Line\n" in a.data
        else:
            assert a.media_type == "image/svg+xml" and b"<svg" in a.data[:2000]
    assert synthetic_result.model_dump_json() == before  # inputs not mutated
    assert synthetic_request.model_dump_json() == req_before


def test_progress_and_cancellation(synthetic_request):
    from plantsolve.solvers.base import Cancelled

    seen = []

    def progress(f, msg=""):
        seen.append(f)
        if f > 0.7:
            raise Cancelled()

    with pytest.raises(Cancelled):
        solve(synthetic_request, progress)
    assert seen == sorted(seen) and seen[0] < 0.1


def test_deterministic(synthetic_request, synthetic_result):
    """Bit for bit, except the diagnostic error table of the efficiency families: on these
    exact cubic data ``parabola_log`` ends its fit in a flat valley at ~2e-6 error, where the
    last bits of BLAS sums (which depend on memory alignment with single-threaded OpenBLAS)
    move where it stops (by ~4e-7). Its numbers agree to 1e-5; everything the map uses is exact."""
    again = solve(synthetic_request).result
    table_again = again.efficiency_error_table
    table_first = synthetic_result.efficiency_error_table
    assert [r.family for r in table_again] == [r.family for r in table_first]
    for a, b in zip(table_again, table_first):
        for name in ("max_rel_error", "max_abs_error", "loo_rel", "loo_abs", "max_overshoot"):
            assert getattr(a, name) == pytest.approx(getattr(b, name), rel=1e-9, abs=1e-5)
        assert a.chosen == b.chosen
    exact = {"efficiency_error_table"}
    assert again.model_dump_json(exclude=exact) == synthetic_result.model_dump_json(exclude=exact)


def test_auto_picks_the_generating_family_and_falls_back_without_loo():
    res = solve(PerfmapRequest.model_validate(
        request_body(n_theta=3, n_phi=3, options={"model": "auto", "grid": [12, 12]}))).result
    assert res.family == "cubic"  # data are cubic Beziers: LOO exact only for 'cubic'
    assert res.report.details["family_choice"]["mean_pressure_loo"]["cubic"] < 1e-12
    # the efficiency family is chosen on its own, per setting: also exact only for 'cubic'
    assert all(s.efficiency_family == "cubic" for s in res.settings)
    res = solve(PerfmapRequest.model_validate(
        request_body(n_theta=3, n_phi=3, n_points=3, options={"model": "auto", "grid": [12, 12]}))).result
    assert res.family == "parabola"
    assert any(w.code == "auto_without_loo" for w in res.report.warnings)


def test_extreme_duty_points_and_grids_are_refused_by_the_schema():
    with pytest.raises(ValidationError):
        PerfmapQueryRequest.model_validate({"flow": 1e308, "pressure": 1.0})
    with pytest.raises(ValidationError):
        PerfmapRequest.model_validate({**_body(), "options": {"grid": [1000, 1000]}})


def test_a_json_request_cut_short_is_refused_naming_where_it_stops():
    text = json.dumps(_body(grid=[30, 30]), indent=2)
    cut = text[:len(text) // 2]
    with pytest.raises(InputRejected) as exc:
        parse_upload(StoredInput.from_bytes("m.json", cut.encode()), None)
    (fe,) = exc.value.errors
    assert fe.loc == ("file",) and "ends before" in fe.msg and f"line {cut.count(chr(10)) + 1}" in fe.msg


def _counts(request) -> tuple[int, int]:
    return len(request.positions), sum(len(p.flow) for p in request.positions)


def test_a_stray_quote_or_an_overlong_field_costs_its_own_line_only(n3_csv):
    """A data line opening a quote it never closes used to swallow every line after it into one cell (130 of the
    fan map's 134 points lost, reported as one skipped line); a field past the csv module's 128 KiB limit refused
    the file as malformed. Now each data line is split on its own: that line is skipped, named, the rest read."""
    lines = n3_csv.decode().splitlines()
    whole = _counts(parse_upload(StoredInput.from_bytes("m.csv", n3_csv), None))
    for bad, reason in (('"' + lines[5], "theta '0.0,0.5,"), ('"' + "1 " * 100_000, "cannot be split into cells"),
                        ("1 " * 100_000, "theta '1 1 1 1 1 1 1 1 1 1 1 1 1 1 1 1 1 1 1 1 …' is not a number")):
        text = "\n".join(lines[:5] + [bad] + lines[6:]) + "\n"
        request = parse_upload(StoredInput.from_bytes("m.csv", text.encode()), None)
        assert _counts(request) == (whole[0], whole[1] - 1)
        (note,) = [w for w in request.upload_warnings if w.code == "upload_rows_skipped"]
        assert note.details["lines"] == [6] and reason in note.details["skipped"][0]["reason"]


def test_a_header_cell_with_a_line_break_keeps_the_line_numbers_of_the_rows_below(n3_csv):
    """Excel writes a header cell typed with Alt+Enter as one quoted cell over two lines ('"theta<LF>[deg]"'): its
    unit is read, and a bad row below is named by its line in the file (before, one line too early)."""
    lines = n3_csv.decode().splitlines()
    header = lines[0].split(",")
    header[0] = '"' + header[0] + '\n[deg]"'
    lines[6] = lines[6].replace("0.0", "abc", 1)
    request = parse_upload(StoredInput.from_bytes("m.csv", ("\n".join([",".join(header)] + lines[1:]) + "\n").encode()),
                           None)
    assert request.setting_units[0] == "deg"
    (note,) = [w for w in request.upload_warnings if w.code == "upload_rows_skipped"]
    assert note.details["lines"] == [8]  # line 7 of the one-line header's file


def test_a_quoted_note_over_two_lines_stays_one_row_and_a_stray_quote_stays_one_line(n3_csv):
    """A notes column typed with Alt+Enter in Excel writes one quoted cell over two lines: that row is read whole
    (its note ignored like any unknown column) and the rows below keep their file line numbers."""
    lines = n3_csv.decode().splitlines()
    lines[0] += ",note"
    lines[3] += ',"surge at\nthe end"'
    lines[5] = lines[5].replace("0.0", "abc", 1)
    request = parse_upload(StoredInput.from_bytes("m.csv", ("\n".join(lines) + "\n").encode()), None)
    whole = _counts(parse_upload(StoredInput.from_bytes("m.csv", n3_csv), None))
    assert _counts(request) == (whole[0], whole[1] - 1)  # only the row made bad on purpose is skipped
    (note,) = [w for w in request.upload_warnings if w.code == "upload_rows_skipped"]
    assert note.details["lines"] == [7]  # its line 6 in the list, one further down in the file


def test_two_stray_quotes_a_few_lines_apart_do_not_make_one_row_of_the_lines_between(n3_csv):
    lines = n3_csv.decode().splitlines()
    whole = _counts(parse_upload(StoredInput.from_bytes("m.csv", n3_csv), None))
    lines[5] = '"' + lines[5]
    lines[8] = lines[8].replace(",", '",', 1)
    request = parse_upload(StoredInput.from_bytes("m.csv", ("\n".join(lines) + "\n").encode()), None)
    assert _counts(request) == (whole[0], whole[1] - 1)
