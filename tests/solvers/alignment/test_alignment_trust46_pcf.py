"""A plant coordinate of a PCF typed 0 (or with a digit dropped) lost a connection without a word: a pipe end moved
along its axis runs past its neighbour, an elbow's end moved away from its CENTRE-POINT points elsewhere. Both
are said now, naming the lines; the exports' own files say nothing."""

from pathlib import Path

import pytest

from plantsolve.solvers.alignment.pcf import interpret_pcf
from plantsolve.solvers.alignment.solve import solve
from plantsolve.solvers.alignment.upload import parse_upload
from plantsolve.solvers.base import StoredInput

LADDER = (Path(__file__).parents[3] / "examples" / "alignment" / "ladder.pcf").read_text()
DATA = Path(__file__).parent / "data"
PIPE_END = "    END-POINT 1000149.073349473 200005.21387331057 9997.108579554855 100.0000"  # P1's first end
ELBOW_END = "    END-POINT 1000146.9120824243 202997.80344555186 9995.887503446393 100.0000"  # N0-1's first end


def _typed(line: str, axis: int, value: str) -> str:
    parts = line.split()
    parts[1 + axis] = value
    assert line in LADDER
    return LADDER.replace(line, "    " + " ".join(parts))


def _line_of(text: str, line: str) -> int:
    return text.splitlines().index(line) + 1


def _warnings(text: str) -> dict:
    return {code: (message, details) for code, message, details, level in interpret_pcf(text, {}).notes
            if level == "warning"}


def test_a_pipe_end_typed_0_along_its_axis_names_the_pipe_and_the_end_it_runs_through():
    text = _typed(PIPE_END, 0, "0")
    req = parse_upload(StoredInput.from_bytes("ladder.pcf", text.encode()), {"fixed_components": ["N0-0"]})
    report = solve(req).result.report
    (warning,) = [w for w in report.warnings if w.code == "pcf_open_end_inside_pipe"]
    (found,) = warning.details["items"]
    elbow_end = _line_of(LADDER, "    END-POINT 1000150.0000 200000.0000 10000.0000 100.0000")
    assert (found["pipe"], found["item"], found["end_point_line"]) == ("P1", "N0-0", elbow_end)
    assert LADDER.splitlines()[found["pipe_line"] - 1] == "PIPE" and f"line {elbow_end}" in warning.message


@pytest.mark.parametrize("axis", [1, 2])  # x = 0 lies 1e6 mm out: left out as a port far outside its network
def test_an_elbow_end_typed_0_is_held_naming_its_line(axis):
    text = _typed(ELBOW_END, axis, "0")
    message, details = _warnings(text)["pcf_items_held"]
    (held,) = [h for h in details["items"] if h["id"] == "N0-1"]
    assert f"end point on line {_line_of(LADDER, ELBOW_END)} lies" in held["reason"]
    assert "arms are equal" in held["reason"] and "arms are equal" in message


@pytest.mark.parametrize("path", [*sorted(DATA.glob("*.pcf")), Path(__file__).parents[3] / "examples" / "alignment"
                                  / "ladder.pcf"], ids=lambda p: p.name)
def test_exports_and_fixtures_raise_neither(path):
    text = path.read_bytes().decode("utf-8", errors="replace")
    warnings = _warnings(text)
    assert "pcf_open_end_inside_pipe" not in warnings
    assert "arms are equal" not in warnings.get("pcf_items_held", ("", {}))[0]
