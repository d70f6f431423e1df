"""The mistakes users make with a meter request: a wrong length unit, absurd numbers, another kind's request. Each
is refused naming the field, or answered with a warning that names the quantity, the value and the likely mix-up;
the signal carries its unit."""

from __future__ import annotations

import json

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from pydantic import ValidationError

from plantsolve.schemas.flowmeter import FlowmeterRequest
from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.flowmeter.artifacts import figures, render_artifacts
from plantsolve.solvers.flowmeter.solve import solve
from plantsolve.solvers.flowmeter.synthetic import exact_full_length, example, meter
from plantsolve.solvers.flowmeter.upload import parse_upload
from plantsolve.solvers.flowmeter.validation import check_input


@pytest.fixture(scope="module")
def in_mm():
    request = FlowmeterRequest.model_validate(example())
    return request, solve(request)


@pytest.fixture(scope="module")
def in_m():
    """The example's numbers (a 50 mm pipe) with units 'm': a 100 m bore."""
    request = FlowmeterRequest.model_validate({**example(), "units": "m"})
    return request, solve(request)


def test_the_signal_is_in_volts_and_millivolts_and_its_conversion_is_stated(in_mm):
    _, solved = in_mm
    result = solved.result
    s = exact_full_length(22.5)
    # U = 2 R B v_mean S: 2 x 0.05 m x 0.01 T x 2 m/s x S
    assert result.signal == pytest.approx(2 * 0.05 * 0.01 * 2.0 * s, rel=1e-6)
    assert result.signal_unit == "V" and result.signal_mv == pytest.approx(1e3 * result.signal)
    assert result.units == "mm" and result.grid_units == ["mm", "mm", "1"]
    (conversion,) = result.report.details["source"]["conversions"]
    assert conversion["from_unit"] == "mm" and conversion["to_unit"] == "m" and conversion["factor"] == 1e-3
    assert not [w for w in result.report.warnings if w.code.startswith("implausible_")]


def test_a_50_mm_pipe_written_in_metres_warns_about_the_bore_and_the_signal(in_mm, in_m):
    _, solved = in_m
    result = solved.result
    assert result.signal == pytest.approx(1000 * in_mm[1].result.signal, rel=1e-9)  # the same S, a 1000x bore
    codes = {w.code: w for w in result.report.warnings}
    bore, signal = codes["implausible_meter_bore"], codes["implausible_signal"]
    assert bore.details["diameter_m"] == pytest.approx(100.0)
    assert "in mm" in bore.message and "'m'" in bore.message and "pipe radius of 50 m" in bore.message
    assert f"{result.signal:.4g} V" in signal.message and signal.details["value_v"] == result.signal
    assert result.report.status == "warning"


@pytest.mark.parametrize("change, loc", [
    ({"magnetic_field": {"type": "uniform", "magnitude": 1e3}}, ("magnetic_field", "uniform", "magnitude")),
    ({"velocity": {"type": "uniform", "mean": 1e5}}, ("velocity", "mean")),
    ({"reynolds": [1e4, 1e300]}, ("reynolds", 1)),
    ({"pipe": {"radius": 1e300}}, ("pipe", "radius")),
])
def test_absurd_scalars_are_refused_by_the_schema_naming_the_field(change, loc):
    with pytest.raises(ValidationError) as error:
        FlowmeterRequest.model_validate({**example(), **change})
    assert error.value.errors()[0]["loc"] == loc


@pytest.mark.parametrize("units, radius", [("mm", 5e6), ("m", 5e3), ("mm", 1e-3), ("ft", 1e4)])
def test_a_bore_no_pipe_has_is_refused_naming_the_radius(units, radius):
    body = meter(radius=radius, units=units)
    with pytest.raises(InputRejected) as error:
        check_input(FlowmeterRequest.model_validate(body))
    assert error.value.errors[0].loc == ("pipe", "radius") and f"{radius:g} {units}" in error.value.errors[0].msg


def test_field_and_velocity_outside_a_meters_range_are_warned_about():
    body = {**meter(radius=50.0), "magnetic_field": {"type": "uniform", "magnitude": 5.0},
            "velocity": {"type": "uniform", "mean": 200.0}}
    result = solve(FlowmeterRequest.model_validate(body)).result
    codes = {w.code: w for w in result.report.warnings}
    assert codes["implausible_magnetic_field"].details["value"] == 5.0 and "mT" in codes["implausible_magnetic_field"].message
    assert codes["implausible_velocity"].details["value"] == 200.0 and "mm/s" in codes["implausible_velocity"].message
    # 2 x 0.05 m x 5 T x 200 m/s x S: 100 V across the electrodes
    assert codes["implausible_signal"].details["value_v"] == pytest.approx(100 * exact_full_length(22.5), rel=1e-6)


@pytest.mark.parametrize("body, kind", [
    ({"positions": [{"theta": 0, "phi": 0, "flow": [1, 2, 3], "pressure": [3, 2, 1], "efficiency": [0.5] * 3}]},
     "perfmap"),
    ({"points": [[0, 0, 0]] * 100, "units": "mm"}, "tube"),
    ({"components": [], "connections": []}, "alignment"),
])
def test_another_kinds_request_uploaded_as_a_meter_is_refused_naming_the_kind(body, kind):
    with pytest.raises(InputRejected) as error:
        parse_upload(StoredInput.from_bytes("request.json", json.dumps(body).encode()), None)
    (e,) = error.value.errors
    assert e.loc == ("file",) and f" {kind} request" in e.msg and f"/v1/{kind}/jobs" in e.msg


def test_the_weight_function_plot_and_table_reach_the_wall(in_mm):
    request, solved = in_mm
    radius = request.pipe.radius
    grid = np.asarray(solved.result.grid)
    r = np.hypot(grid[:, 0], grid[:, 1])
    assert r.max() > radius * (1 - 1e-5) and np.isfinite(grid).all()
    # every direction: the table's outermost node within a hair of the wall (it stopped 2.5 mm short before)
    angle = np.arctan2(grid[:, 1], grid[:, 0])
    for sector in np.array_split(np.argsort(angle), 64):
        assert r[sector].max() > radius * (1 - 1e-5)
    fig = figures(request, solved.result)["weight_function"]
    FigureCanvasAgg(fig).draw()
    ax = fig.axes[0]
    filled = [c for c in ax.collections if type(c).__name__ in ("QuadContourSet", "TriContourSet", "ContourSet")
              and c.get_array() is not None and len(c.get_paths())]
    vertices = np.vstack([p.vertices for c in filled for p in c.get_paths() if len(p.vertices)])
    reach = np.hypot(vertices[:, 0], vertices[:, 1])
    assert reach.max() > radius * (1 - 1e-4)
    # points of the former blank band (0.2 to 2 mm inside the wall, all round) are coloured
    t = np.linspace(0, 2 * np.pi, 360, endpoint=False)
    for depth in (0.2, 1.0, 2.0):
        ring = (radius - depth) * np.column_stack([np.cos(t), np.sin(t)])
        coloured = np.zeros(len(ring), bool)
        for c in filled:
            for path in c.get_paths():
                if len(path.vertices):
                    coloured |= path.contains_points(ring)
        assert coloured.all(), f"{(~coloured).sum()} of 360 points {depth} mm inside the wall are blank"
    csv = next(a for a in render_artifacts(request, solved) if a.name == "weight_grid.csv").data.decode()
    assert csv.splitlines()[0] == "x [mm],y [mm],W [-]" and len(csv.splitlines()) == len(grid) + 1


def test_a_half_angle_in_radians_is_warned_about_naming_the_field():
    """0.3927 (pi/8 rad, the example's 22.5 degrees) typed into the degrees field: a patch under 1 degree wide, whose
    sensitivity (~1.0, point-like) is not the meter's (~0.965)."""
    from plantsolve.solvers.flowmeter.plausibility import request_warnings
    as_radians = FlowmeterRequest.model_validate({**example(), "electrodes": {**example()["electrodes"],
                                                                              "half_angle": np.pi / 8}})
    (warning,) = [w for w in request_warnings(as_radians, 0.01) if w.code == "implausible_electrode_half_angle"]
    assert warning.details["quantity"] == "electrodes.half_angle"
    assert warning.details["as_radians_deg"] == pytest.approx(22.5)
    assert "radians" in warning.message
    in_degrees = FlowmeterRequest.model_validate(example())
    assert not request_warnings(in_degrees, 0.01)


def _sampled_request(points: list, values: list) -> FlowmeterRequest:
    return FlowmeterRequest.model_validate({**example(), "velocity": {"type": "samples", "points": points,
                                                                       "values": values}})


def test_a_sample_point_given_twice_with_two_values_is_refused_naming_both():
    """A uniform 2 m/s profile sampled on rings; a copied row whose value was edited makes the point ambiguous (the
    triangulation kept one value without a word). The same point with the same value is accepted."""
    points = [[0.0, 0.0]] + [[r * np.cos(a), r * np.sin(a)] for r in (20.0, 40.0, 50.0)
                             for a in np.linspace(0, 2 * np.pi, 12, endpoint=False)]
    values = [2.0] * len(points)
    check_input(_sampled_request(points + [points[5]], values + [2.0]))
    with pytest.raises(InputRejected) as refused:
        check_input(_sampled_request(points + [points[5]], values + [5.0]))
    (error,) = refused.value.errors
    assert error.loc == ("velocity", "points", len(points)) and "points[5]" in error.msg and "5 against 2" in error.msg
