"""A PIPE whose two END-POINTs were typed the same is named with its line and zero length (read as a joint, the
item beyond it is left open); bores that disagree where they should agree (an item's two ends, two mated ends) are
named with both lines and both bores; a reducer's change of bore is not."""

from pathlib import Path

import pytest

from plantsolve.solvers.alignment.pcf import interpret_pcf
from plantsolve.solvers.alignment.solve import solve
from plantsolve.solvers.alignment.upload import parse_upload
from plantsolve.solvers.base import StoredInput

DATA = Path(__file__).parent / "data"
SP3D = (DATA / "sp3d_inch_tabs.pcf").read_text()

LINE = ("ISOGEN-FILES ISOGEN.FLS\nUNITS-BORE MM\nUNITS-CO-ORDS MM\nPIPELINE-REFERENCE TEST-1\n"
        "PIPE\n    END-POINT 0.0000 0.0000 0.0000 100.0000\n    END-POINT 1000.0000 0.0000 0.0000 100.0000\n"
        "ELBOW\n    END-POINT 1000.0000 0.0000 0.0000 100.0000\n    END-POINT 1152.4000 152.4000 0.0000 100.0000\n"
        "    CENTRE-POINT 1152.4000 0.0000 0.0000\n"
        "PIPE\n    END-POINT 1152.4000 152.4000 0.0000 100.0000\n    END-POINT 1152.4000 1152.4000 0.0000 100.0000\n")


def _report(text: str):
    return solve(parse_upload(StoredInput.from_bytes("line.pcf", text.encode()), {})).result.report


def _warnings(text: str) -> dict:
    return {code: (message, details) for code, message, details, level in interpret_pcf(text, {}).notes
            if level == "warning"}


def test_a_pipe_whose_end_points_were_typed_the_same_is_named_with_its_line_and_length():
    # the last PIPE's far END-POINT typed as its near one: before, the report said nothing of it
    text = LINE.replace("END-POINT 1152.4000 1152.4000 0.0000", "END-POINT 1152.4000 152.4000 0.0000")
    report = _report(text)
    (warning,) = [w for w in report.warnings if w.code == "pcf_zero_length_pipe"]
    (found,) = warning.details["items"]
    assert (found["id"], found["line"], found["end_point_lines"]) == ("PIPE-3", 12, [13, 14])
    assert found["length"] == 0.0 and found["unit"] == "mm"
    assert "PIPE-3 (line 12" in warning.message and "length 0 mm" in warning.message


@pytest.mark.parametrize("far, length", [("1152.4000 152.5000", 0.1), ("1152.4000 154.4000", 2.0)])
def test_a_pipe_whose_far_end_point_was_typed_next_to_its_near_one_is_named(far, length):
    report = _report(LINE.replace("END-POINT 1152.4000 1152.4000 0.0000", f"END-POINT {far} 0.0000"))
    (warning,) = [w for w in report.warnings if w.code == "pcf_zero_length_pipe"]
    (found,) = warning.details["items"]
    assert found["id"] == "PIPE-3" and found["length"] == pytest.approx(length) and found["unit"] == "mm"


def test_a_whole_line_names_no_zero_length_pipe():
    assert "pcf_zero_length_pipe" not in {w.code for w in _report(LINE).warnings}
    # a pup of one bore is a pipe
    pup = LINE.replace("END-POINT 1152.4000 1152.4000 0.0000", "END-POINT 1152.4000 252.4000 0.0000")
    assert "pcf_zero_length_pipe" not in {w.code for w in _report(pup).warnings}


def test_a_bore_in_mm_in_an_inch_bore_file_is_named_with_both_lines_and_bores():
    # the first pipe's far end written as 152.4 (6 in, in mm) where its mate, the cross, says 4 in
    lines = SP3D.splitlines()
    n = next(k for k, line in enumerate(lines) if line.startswith("\tend-point\t-40.04"))
    lines[n] = lines[n].replace("4.0000", "152.4000")
    (warning,) = [w for w in _report("\n".join(lines) + "\n").warnings if w.code == "pcf_bore_mismatch"]
    message, details = warning.message, warning.details
    pairs = {(p["where"], p["line"], p["bore"], p["other_line"], p["other_bore"]) for p in details["pairs"]}
    # against the pipe's own other end, and against the cross's end it joins (line 21)
    assert pairs == {("item", 17, 4.0, 18, 152.4), ("connection", 18, 152.4, 21, 4.0)}
    assert details["unit"] == "in"
    assert "line 17 bore 4 against line 18 bore 152.4" in message
    assert "line 18 bore 152.4 against line 21 bore 4" in message


def test_a_reducers_change_of_bore_is_not_named_but_an_implausible_one_is():
    assert "pcf_bore_mismatch" not in _warnings(SP3D)  # its eccentric reducer goes 4 in to 3 in
    lines = SP3D.splitlines()
    n = next(k for k, line in enumerate(lines) if line.startswith("\tend-point\t-36\t24.98"))
    reducer = lines[n]
    lines[n] = reducer.replace("3.0000", "0.3000")  # a dropped digit: 4 in to 0.3 in is no reducer
    (pair, *_) = _warnings("\n".join(lines) + "\n")["pcf_bore_mismatch"][1]["pairs"]
    assert (pair["where"], pair["line"], pair["bore"], pair["other_line"], pair["other_bore"]) == (
        "item", n, 4.0, n + 1, 0.3)


@pytest.mark.parametrize("path", [*sorted(DATA.glob("*.pcf")), Path(__file__).parents[3] / "examples" / "alignment"
                                  / "ladder.pcf"], ids=lambda p: p.name)
def test_exports_and_fixtures_raise_no_bore_mismatch_or_zero_length_pipe(path):
    assert not {"pcf_bore_mismatch", "pcf_zero_length_pipe"} & set(
        _warnings(path.read_bytes().decode("utf-8", errors="replace")))


def test_fittings_change_bore_and_pipes_keep_it():
    text = ("UNITS-BORE MM\nUNITS-CO-ORDS MM\n"
            "PIPE\n    END-POINT 0.0 0.0 0.0 100.0\n    END-POINT 1000.0 0.0 0.0 100.0\n"
            "SWAGE\n    END-POINT 1000.0 0.0 0.0 100.0\n    END-POINT 1150.0 0.0 0.0 12.5\n"
            "PIPE\n    END-POINT 1150.0 0.0 0.0 12.5\n    END-POINT 2150.0 0.0 0.0 12.5\n")
    # a swage nipple 8:1, a reducing coupling, an in-line instrument: fittings that change bore
    for word in ("SWAGE", "COUPLING", "INSTRUMENT", "VALVE"):
        assert "pcf_bore_mismatch" not in _warnings(text.replace("SWAGE", word)), word
    (pair,) = _warnings(text.replace("SWAGE", "PIPE"))["pcf_bore_mismatch"][1]["pairs"]  # a pipe keeps its bore
    assert (pair["where"], pair["line"], pair["bore"], pair["other_line"], pair["other_bore"]) == (
        "item", 7, 100.0, 8, 12.5)
    # a bore of a fitting written in mm in an inch-bore file: 25.4 times, beyond any fitting
    inch = text.replace("UNITS-BORE MM", "UNITS-BORE INCH").replace(" 100.0", " 4.0").replace(" 12.5", " 2.0")
    assert "pcf_bore_mismatch" not in _warnings(inch)
    pairs = _warnings(inch.replace("1150.0 0.0 0.0 2.0\nPIPE", "1150.0 0.0 0.0 50.8\nPIPE", 1)
                      )["pcf_bore_mismatch"][1]["pairs"]
    assert {(p["where"], p["line"], p["bore"], p["other_line"], p["other_bore"]) for p in pairs} == {
        ("item", 7, 4.0, 8, 50.8), ("connection", 8, 50.8, 10, 2.0)}
