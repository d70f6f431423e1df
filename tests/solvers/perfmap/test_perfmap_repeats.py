"""Repeated readings of one setting at one flow that disagree by ~20 % (two rigs' runs mixed in one line) were
averaged with only a repeated_flows_averaged count; the warning now names the spread and the lines."""

from __future__ import annotations

import pytest

from plantsolve.schemas.perfmap import PerfmapRequest
from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.perfmap.synthetic import request_body
from plantsolve.solvers.perfmap.upload import parse_upload
from plantsolve.solvers.perfmap.validation import load
from tests.solvers.perfmap.conftest import DATA

LINES = (DATA / "n3_fan_map.csv").read_text().replace("\r\n", "\n").splitlines()  # theta,phi,flow,pressure,eff


def _load_table(lines: list[str]):
    source = StoredInput.from_bytes("rig.csv", ("\n".join(lines) + "\n").encode())
    return load(parse_upload(source, {"map": False}), source)


def _repeat_of_row(k: int, pressure_factor: float, efficiency_factor: float = 1.0) -> str:
    theta, phi, flow, pressure, eta = LINES[k].split(",")
    return ",".join([theta, phi, flow, repr(float(pressure) * pressure_factor), repr(float(eta) * efficiency_factor)])


def test_a_repeat_twenty_per_cent_off_is_named_with_its_spread_and_lines():
    lines = LINES + [_repeat_of_row(3, 1.2)]  # file line 4's point again, another rig's pressure
    value = _load_table(lines)
    (warning,) = [w for w in value.warnings if w.code == "repeated_points_disagree"]
    (group,) = warning.details["groups"]
    assert group["lines"] == [4, len(lines)]
    assert group["pressure_spread"] == pytest.approx(0.2 / 1.1)  # (1.2 p - p) / 1.1 p
    assert "lines 4, " in warning.message and "18.2% apart" in warning.message


def test_an_efficiency_repeat_off_is_named_and_a_close_repeat_is_not():
    value = _load_table(LINES + [_repeat_of_row(5, 1.0, 0.8)])
    (warning,) = [w for w in value.warnings if w.code == "repeated_points_disagree"]
    assert warning.details["groups"][0]["efficiency_spread"] == pytest.approx(0.2 / 0.9)
    close = _load_table(LINES + [_repeat_of_row(5, 1.01, 0.995)])  # one rig's repeat run: averaged, no alarm
    assert "repeated_points_disagree" not in {w.code for w in close.warnings}


def test_a_json_body_names_the_points_of_the_position():
    body = request_body()
    body["options"] = {**body.get("options", {}), "map": False}
    p = body["positions"][4]
    for key, factor in (("flow", 1.0), ("pressure", 1.25), ("efficiency", 1.0)):
        p[key] = p[key] + [p[key][2] * factor]
    value = load(PerfmapRequest.model_validate(body))
    (warning,) = [w for w in value.warnings if w.code == "repeated_points_disagree"]
    group = warning.details["groups"][0]
    assert group["position"] == 4 and sorted(group["points"]) == [2, len(p["flow"]) - 1] and group["lines"] is None
    assert group["pressure_spread"] == pytest.approx(0.25 / 1.125)
