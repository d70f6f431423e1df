"""Plots drawn with less work and the same content: a figure's formats laid out once, log axes' decades and the
flow meter's arrow marker without mathtext, contour labels thinned without a whole draw, perfmap's boundary
distance a band chunk at a time, and dedup's chart the same for the same result."""

from __future__ import annotations

import io

import numpy as np
import pytest
from matplotlib import mathtext
from matplotlib.figure import Figure
from matplotlib.layout_engine import ConstrainedLayoutEngine

from plantsolve.schemas.dedup import DedupResult
from plantsolve.solvers.dedup import artifacts as dedup_artifacts
from plantsolve.solvers.flowmeter import artifacts as flowmeter_artifacts
from plantsolve.solvers.kinds import KINDS
from plantsolve.solvers.perfmap import artifacts as perfmap_artifacts
from plantsolve.solvers.plots import decade_label, figure_artifacts, plain_decades


def _solved(kind: str):
    spec = KINDS[kind]
    job_input = spec.input_of(spec.request_model.model_validate(spec.example()))
    return spec, job_input, spec.solve(job_input, lambda *_: None)


@pytest.fixture(scope="module")
def perfmap_example():
    return _solved("perfmap")


@pytest.fixture
def layouts(monkeypatch):
    """Every run of constrained layout, by figure."""
    runs = []
    execute = ConstrainedLayoutEngine.execute

    def counted(self, fig):
        runs.append(fig)
        return execute(self, fig)

    monkeypatch.setattr(ConstrainedLayoutEngine, "execute", counted)
    return runs


def _constrained_figure() -> Figure:
    fig = Figure(figsize=(5, 3.5), layout="constrained")
    ax = fig.add_subplot()
    ax.plot([0, 1, 2], [3, 1, 2], label="data")
    ax.set(xlabel="flow [kg/s]", ylabel="pressure ratio [-]", title="a map")
    fig.legend(loc="outside lower center")
    return fig


def test_a_figures_formats_are_laid_out_once_at_the_same_places(layouts):
    fig = _constrained_figure()
    png, svg = figure_artifacts("map", fig)
    assert [a.name for a in (png, svg)] == ["map.png", "map.svg"]
    assert [a.media_type for a in (png, svg)] == ["image/png", "image/svg+xml"]
    assert png.data[:8] == b"\x89PNG\r\n\x1a\n" and b"<svg" in svg.data
    assert b"<dc:date>" not in svg.data  # the same result, the same SVG
    assert len(layouts) == 1
    # the SVG's axes stand where the PNG's layout put them: the same figure laid out for the PNG alone
    alone = _constrained_figure()
    alone.savefig(io.BytesIO(), format="png", dpi=110)
    assert np.allclose(fig.axes[0].get_position().bounds, alone.axes[0].get_position().bounds)


def test_perfmap_lays_each_figure_out_once_for_its_png_and_svg(perfmap_example, layouts, monkeypatch):
    spec, job_input, solved = perfmap_example
    # the envelopes alone (constrained layout; the map's boundary field would only make the test slow)
    monkeypatch.setattr(perfmap_artifacts, "figures", lambda value, result: {"envelopes": perfmap_artifacts._envelopes(result)})
    artifacts = spec.render_artifacts(job_input, solved)
    assert [a.name for a in artifacts if a.name.startswith("envelopes")] == ["envelopes.png", "envelopes.svg"]
    assert len(layouts) == 1


def test_decades_are_written_as_plain_text():
    assert [decade_label(v) for v in (1.0, 1000.0, 1e6, 1e-6, 0.1, 0.0, -100.0)] == [
        "10⁰", "10³", "10⁶", "10⁻⁶", "10⁻¹", "0", "−10²"]
    assert decade_label(2000.0) == "" and decade_label(float("nan")) == ""
    fig = Figure()
    ax = fig.add_subplot()
    ax.semilogx([1e3, 1e6], [0.96, 0.97])
    plain_decades(ax.xaxis)
    fig.draw_without_rendering()
    shown = [t.get_text() for t in ax.xaxis.get_ticklabels() if 1e3 <= t.get_position()[0] <= 1e6]
    assert shown == ["10³", "10⁴", "10⁵", "10⁶"]


@pytest.fixture
def no_mathtext(monkeypatch):
    def refuse(self, s, *args, **kwargs):
        raise AssertionError(f"mathtext asked to lay out {s!r}")

    monkeypatch.setattr(mathtext.MathTextParser, "parse", refuse)


@pytest.fixture(scope="module")
def flowmeter_example():
    return _solved("flowmeter")


def test_the_flowmeters_log_axes_and_arrow_marker_need_no_mathtext(flowmeter_example, no_mathtext):
    _, request, solved = flowmeter_example
    figures = flowmeter_artifacts.figures(request, solved.result)
    for stem in ("electrode_current", "linearity"):
        figures[stem].savefig(io.BytesIO(), format="png", dpi=110)


@pytest.mark.parametrize("kind", ["dedup", "alignment"])
def test_log_axes_need_no_mathtext(kind, no_mathtext):
    spec, job_input, solved = _solved(kind)
    assert any(a.name.endswith(".png") for a in spec.render_artifacts(job_input, solved))


def test_the_weight_maps_labels_are_thinned_without_a_whole_draw(flowmeter_example, no_mathtext, monkeypatch):
    artifacts = flowmeter_artifacts
    _, request, solved = flowmeter_example
    draws = []
    monkeypatch.setattr(Figure, "draw_without_rendering", lambda self: draws.append(self))
    fig = artifacts.weight_map(request, solved.result)
    assert draws == []
    fig.savefig(io.BytesIO(), format="png", dpi=110)  # its legend's arrow marker is a glyph path, not mathtext
    labels = [t for t in fig.axes[0].texts if t.get_text()]
    shown = [t for t in labels if t.get_visible()]
    assert labels and 0 < len(shown) <= len(labels)
    renderer = fig._get_renderer()
    boxes = [t.get_window_extent(renderer) for t in shown]
    assert not any(a.overlaps(b) for i, a in enumerate(boxes) for b in boxes[i + 1:])


def test_perfmaps_boundary_distance_is_the_same_field_a_chunk_at_a_time(perfmap_example, monkeypatch):
    _, _, solved = perfmap_example
    monkeypatch.setattr(perfmap_artifacts, "_BOUNDARY_NODES", 90)  # a coarser field: the same rule, a faster test
    sizes = []
    distance = perfmap_artifacts.distance_to_region

    def recorded(curves, tri, t, x, y, ranges):
        sizes.append(len(x))
        return distance(curves, tri, t, x, y, ranges)

    monkeypatch.setattr(perfmap_artifacts, "distance_to_region", recorded)
    fx, fy, d = perfmap_artifacts.reachable_boundary(solved.result)
    assert len(sizes) > 1 and max(sizes) <= perfmap_artifacts._BAND_CHUNK
    # the field the whole band at once gives, node for node
    result = solved.result
    FX, FY = np.meshgrid(fx, fy)
    m = result.map
    tri = np.array(result.triangles, dtype=int).reshape(-1, 3)
    band = (d > 0) & (d < 1)
    whole = distance(perfmap_artifacts.curveset_from_fits(result.settings), tri, np.linspace(0.0, 1.0, m.t_samples),
                     FX[band], FY[band], (*result.flow_range, *result.pressure_range))
    assert np.array_equal(d[band], whole)


def _counts(names: list[str]) -> DedupResult:
    before = {n: 3 for n in names}
    return DedupResult.model_construct(entity_counts_before=before, entity_counts_after=dict(before),
                                       original_bytes=100, optimized_bytes=80, sharing="mapped_item",
                                       products_shared=0, products_total=0, optimization_rate=0.2)


def test_dedups_chart_orders_tied_entity_types_by_name():
    names = [f"IfcType{chr(65 + k % 26)}{k:02d}" for k in range(40)][::-1]
    fig = dedup_artifacts.counts_figure(_counts(names))
    shown = [t.get_text() for t in fig.axes[0].get_yticklabels()]
    assert shown == sorted(names)[:dedup_artifacts.MAX_BARS]
