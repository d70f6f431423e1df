"""Every perfmap plot states its units on every axis and keeps its legends off the data; the map's exports
read back."""

from __future__ import annotations

import csv
import io

import numpy as np
import pytest

from plantsolve.solvers.base import Solved, StoredInput
from plantsolve.solvers.perfmap.solve import solve
from plantsolve.solvers.perfmap.upload import parse_upload
from plantsolve.solvers.perfmap.artifacts import (curves_csv, figures, map_csv, reachable_boundary,
                                                  render_artifacts, smooth_on_finer_grid)
from plantsolve.solvers.perfmap.performance_map import distance_to_region
from plantsolve.solvers.perfmap.families import curveset_from_fits
from plantsolve.solvers.perfmap.synthetic import speed_lines
from tests.support.plots import check_figure

LINES = speed_lines(4, 8, steep=6.0)["positions"]


def rig_table(header) -> bytes:
    out = [";".join(header)]
    for p in LINES:
        for f, pr, e in zip(p["flow"], p["pressure"], p["efficiency"]):
            out.append(";".join(str(v) for v in (p["setting"][0] * 10000, f, pr, 100 * e)))
    return "\n".join(out).encode()


@pytest.fixture(scope="module")
def rig():
    req = parse_upload(StoredInput.from_bytes("rig.csv", rig_table(["Speed [rpm]", "Flow [kg/s]", "Pressure rise [kPa]", "Efficiency [%]"])),
                       {"grid": [24, 24]})
    return req, solve(req).result


def test_every_plot_has_units_on_its_axes_and_legends_off_the_data(rig):
    req, res = rig
    figs = figures(req, res)
    assert set(figs) == {"characteristics", "envelopes", "map"}
    for name, fig in figs.items():
        check_figure(fig)
        labels = [a.get_xlabel() for a in fig.axes] + [a.get_ylabel() for a in fig.axes]
        assert "flow [kg/s]" in labels and (name == "envelopes" or "pressure [kPa]" in labels or name == "map"), name
    assert "Speed [rpm]" in [a.get_ylabel() for a in figs["map"].axes]
    assert figs["map"].axes[0].get_legend() is None and figs["map"].legends  # the legend sits outside the map


def test_the_unit_not_stated_is_said_so(rig):
    req = parse_upload(StoredInput.from_bytes("rig.csv", rig_table(["Speed", "Flow", "Pressure", "Efficiency [%]"])), {"grid": [16, 16]})
    figs = figures(req, solve(req).result)
    labels = {label for fig in figs.values() for a in fig.axes for label in (a.get_xlabel(), a.get_ylabel())}
    assert {"flow (unit as in the file)", "pressure (unit as in the file)", "Speed (unit as in the file)"} <= labels
    # efficiency is a fraction in every result (the file's % divided by 100): never 'unit not stated'
    assert "efficiency η [-]" in labels and not any("not stated" in label for label in labels)
    for fig in figs.values():
        check_figure(fig)


def test_a_csv_pressure_ratio_is_labelled_a_pressure_ratio_and_the_header_units_are_used():
    """A rig table in lbm/s with a pressure ratio ('PR [-]') and efficiency in %: every plot says 'pressure
    ratio [-]' (it used to say 'pressure [-]'), flow in lbm/s, the speed in %."""
    req = parse_upload(StoredInput.from_bytes("rig.csv", rig_table(["Nc [%]", "Wc [lbm/s]", "PR [-]", "eff [%]"])),
                       {"grid": [16, 16]})
    figs = figures(req, solve(req).result)
    labels = {label for fig in figs.values() for a in fig.axes for label in (a.get_xlabel(), a.get_ylabel())}
    assert {"flow [lbm/s]", "pressure ratio [-]", "efficiency η [-]", "Nc [%]"} <= labels
    assert not any(label.startswith("pressure [") for label in labels), labels
    for fig in figs.values():
        check_figure(fig)


def test_the_label_checker_catches_a_bare_axis():
    from matplotlib.figure import Figure
    from tests.support.plots import axis_problems, legend_problems
    fig = Figure()
    ax = fig.subplots()
    ax.plot([0, 1], [0, 1], label="data")
    ax.set(xlabel="flow", ylabel="y")
    ax.legend(loc="center")  # right over the line
    assert len(axis_problems(fig)) == 2 and legend_problems(fig)


def test_the_smooth_boundary_lies_on_the_exact_region(rig):
    """The boundary contour is drawn from the exact distance to the reachable region: at every node of the
    fine grid outside the map's reachable nodes' band the value is the map's verdict, and inside the band the
    distance is exact (0 at a point of a characteristic, which is reachable)."""
    _, res = rig
    fx, fy, d = reachable_boundary(res)
    assert d.shape == (len(fy), len(fx)) and np.all(d >= 0)
    curves = curveset_from_fits(res.settings)
    x, y, _ = curves.evaluate(np.array([0, 3]), np.array([0.5, 0.5]))
    tri = np.array(res.triangles).reshape(-1, 3)
    ranges = (*res.flow_range, *res.pressure_range)
    assert np.allclose(distance_to_region(curves, tri, np.linspace(0, 1, 129), x, y, ranges), 0.0, atol=1e-12)
    # the map's verdict away from its boundary: reachable nodes 0, unreachable ones positive
    m = res.map
    eta = np.array(m.efficiency, dtype=float)
    i = int(np.argmin(abs(np.array(m.flow) - fx[80]))), int(np.argmin(abs(np.array(m.pressure) - fy[80])))
    assert (d[80, 80] == 0) == np.isfinite(eta[i[1], i[0]]) or d[80, 80] < 0.05


def test_smoothing_keeps_a_linear_field_and_the_unreachable_nodes():
    gx, gy = np.linspace(0, 1, 11), np.linspace(0, 2, 21)
    z = 3 * gx[None, :] + gy[:, None]
    z[:4, :3] = np.nan
    fx, fy, fine = smooth_on_finer_grid(gx, gy, z, sigma=0.0)
    exact = 3 * fx[None, :] + fy[:, None]
    ok = np.isfinite(fine)
    assert np.nanmax(abs(fine - exact)[ok & (fy[:, None] > 0.5) & (fx[None, :] > 0.35)]) < 1e-9
    assert not ok[0, 0] and ok[-1, -1]


def test_curves_csv_reads_back_as_the_same_rig(rig):
    req, res = rig
    text = curves_csv(res).decode()
    header = next(csv.reader(io.StringIO(text)))
    assert header == ["Speed [rpm]", "t [-]", "flow [kg/s]", "pressure [kPa]", "efficiency [-]"]
    back = parse_upload(StoredInput.from_bytes("curves.csv", text.encode()), {"map": False, "columns": {"t [-]": "ignore"}})
    assert back.units.flow == "kg/s" and back.units.pressure == "kPa" and back.setting_units == ["rpm"]
    again = solve(back).result
    for a, b in zip(res.settings, again.settings):
        assert a.setting == b.setting and b.x_min == pytest.approx(a.x_min) and b.x_max == pytest.approx(a.x_max)


def test_map_csv_holds_every_node(rig):
    _, res = rig
    rows = list(csv.reader(io.StringIO(map_csv(res).decode())))
    assert rows[0] == ["flow [kg/s]", "pressure [kPa]", "max efficiency [-]", "optimal Speed [rpm]"]
    m = res.map
    assert len(rows) - 1 == len(m.flow) * len(m.pressure)
    j, i = 5, 7
    row = rows[1 + j * len(m.flow) + i]
    assert float(row[0]) == m.flow[i] and float(row[1]) == m.pressure[j]
    assert (row[2] == "") == (m.efficiency[j][i] is None)
    names = [a.name for a in render_artifacts(rig[0], Solved(rig[1]))]
    assert "map.csv" in names and "curves.csv" in names


def test_a_setting_with_few_values_is_contoured_where_the_optimum_changes_side():
    from plantsolve.solvers.perfmap.artifacts import setting_levels

    assert setting_levels(np.array([0.0, 5.0, 0.0, 5.0])) == [2.5]
    assert setting_levels(np.array([0.0, 2.0, 6.0])) == [1.0, 4.0]
    assert setting_levels(np.linspace(0.5, 1.1, 9)) == 8


def _luminance(colour) -> float:
    """WCAG relative luminance of an RGB(A) colour."""
    from matplotlib.colors import to_rgb

    c = np.array(to_rgb(colour))
    c = np.where(c <= 0.03928, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)
    return float(0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2])


def _contrast(a, b) -> float:
    la, lb = sorted((_luminance(a), _luminance(b)), reverse=True)
    return (la + 0.05) / (lb + 0.05)


def test_the_maps_contour_labels_read_on_every_colour_of_the_map(synthetic_request, synthetic_result):
    """Orange or white label text straight on viridis' yellow had a contrast near 1.5:1; each label now sits on a
    light box in a dark shade of its line's colour, whatever lies beneath (WCAG asks 4.5:1 of small text)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.colors import to_rgb
    from matplotlib import colormaps

    fig = figures(synthetic_request, synthetic_result)["map"]
    FigureCanvasAgg(fig).draw()
    labels = [t for t in fig.axes[0].texts if "=" in t.get_text()]
    assert {t.get_text().split("=")[0] for t in labels} == {"θ", "φ"}
    for text in labels:
        box = text.get_bbox_patch()
        assert box is not None, text.get_text()
        alpha = box.get_alpha() if box.get_alpha() is not None else 1.0
        for under in (colormaps["viridis"](0.0), colormaps["viridis"](1.0)):  # darkest and lightest of the map
            seen = alpha * np.array(to_rgb(box.get_facecolor())) + (1 - alpha) * np.array(to_rgb(under))
            assert _contrast(text.get_color(), seen) >= 4.5, (text.get_text(), text.get_color())


def test_the_boundary_distance_is_evaluated_only_where_the_drawing_reads_it():
    """A disk of radius 0.3 (distance max(0, |p - c| - 0.3), closed form): exact at every wanted node within the
    cap, 1 at the others, which lie beyond it; the far nodes are left out by blocks, not one by one."""
    from plantsolve.solvers.perfmap.artifacts import boundary_cap, boundary_level, distance_near

    fx, fy = np.linspace(0.0, 1.0, 120), np.linspace(0.0, 1.0, 90)
    evaluated = []

    def disk(x, y):
        evaluated.append(len(x))
        return np.maximum(np.hypot(x - 0.4, y - 0.55) - 0.3, 0.0)

    wanted = np.ones((len(fy), len(fx)), dtype=bool)
    wanted[:10] = False  # a node not asked for is not evaluated
    cap = boundary_cap(fx, fy)
    assert boundary_level(fx, fy) == pytest.approx(0.25 / 89) and cap == pytest.approx((0.25 + 2 ** 0.5) / 89)
    d = distance_near(disk, fx, fy, wanted, cap)
    exact = np.maximum(np.hypot(fx[None, :] - 0.4, fy[:, None] - 0.55) - 0.3, 0.0)
    close = wanted & (exact <= cap)
    assert np.array_equal(d[close], exact[close]) and np.all(d[~close] == 1.0) and np.all(exact[wanted & ~close] > cap)
    assert sum(evaluated) < 0.6 * wanted.sum(), sum(evaluated)


def test_the_maps_boundary_field_is_the_whole_bands_wherever_it_is_drawn(rig, monkeypatch):
    """The map's boundary field against the band evaluated node by node (the cap lifted): the same at every node
    within the cap (the boundary contour and the filled map's mask read nothing else), beyond it on both sides
    elsewhere, and with fewer points evaluated on a coarse map's wide band."""
    from plantsolve.solvers.perfmap import artifacts

    _, res = rig
    counted = []
    distance = artifacts.distance_to_region

    def recorded(curves, tri, t, x, y, ranges):
        counted.append(len(x))
        return distance(curves, tri, t, x, y, ranges)

    monkeypatch.setattr(artifacts, "distance_to_region", recorded)
    fx, fy, d = reachable_boundary(res)
    pruned = sum(counted)
    counted.clear()
    monkeypatch.setattr(artifacts, "boundary_cap", lambda fx, fy: np.inf)
    _, _, whole = reachable_boundary(res)
    monkeypatch.undo()
    cap = artifacts.boundary_cap(fx, fy)
    close = whole <= cap
    assert np.array_equal(d[close], whole[close]) and np.all(d[~close] > cap)
    assert pruned < 0.7 * sum(counted), (pruned, sum(counted))


def _offset_rig():
    """The rig with its pressures in Pa around 2e6: the y axis writes '1e6' above itself."""
    lines = ["Speed [rpm];Flow [kg/s];Pressure [Pa];Efficiency [%]"]
    for p in LINES:
        for f, pr, e in zip(p["flow"], p["pressure"], p["efficiency"]):
            lines.append(";".join(str(v) for v in (p["setting"][0] * 10000, f, 2e6 * pr, 100 * e)))
    req = parse_upload(StoredInput.from_bytes("rig.csv", "\n".join(lines).encode()), {"grid": [16, 16]})
    return req, solve(req).result


@pytest.mark.parametrize("case", ["rig", "offset"])
def test_the_panels_titles_stand_where_matplotlibs_placement_puts_them(rig, case, monkeypatch):
    """Each characteristics panel's title is placed on its axes' top edge without matplotlib measuring both y axes'
    tick labels at every save (it moves a title only over ticks or an offset text above the axes): the same place
    as the automatic one, and a panel whose y axis writes an offset ('1e6') keeps the automatic placement, which
    lifts its title over it."""
    from matplotlib.axis import YAxis

    from plantsolve.solvers.perfmap import artifacts
    from plantsolve.solvers.plots import figure_bytes

    req, res = rig if case == "rig" else _offset_rig()

    def titles(fig):
        figure_bytes(fig, "png")
        renderer = fig._get_renderer()
        return [ax.title.get_window_extent(renderer).bounds for ax in fig.axes if ax.get_title()]

    measured = []
    tightbbox = YAxis.get_tightbbox
    monkeypatch.setattr(YAxis, "get_tightbbox", lambda self, *a, **k: measured.append(self) or tightbbox(self, *a, **k))
    fig = figures(req, res)["characteristics"]
    placed = titles(fig)
    shown = [ax.yaxis.offsetText.get_text() for ax in fig.axes if ax.get_visible()]
    if case == "rig":
        assert not measured and not any(shown), shown
    else:
        assert measured and "1e6" in shown, shown  # matplotlib measured the offset texts, and lifted the titles
    check_figure(fig)
    monkeypatch.setattr(artifacts, "_title_place", lambda *twins: {})
    assert placed == titles(figures(req, res)["characteristics"])
