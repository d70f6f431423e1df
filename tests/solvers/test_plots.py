"""Every plot of every kind passes the plot checker (tests/support/plots.py) as it is saved: each kind's
example is solved through its SPEC (input_of, solve, render_artifacts), and every PNG artifact's figure —
each kind's ``artifacts.figures(input, result)``, by artifact stem — is checked at the resolution the PNG
was saved at, with the tolerance bands the kind declares (``artifacts.tolerances(input, result)``, by stem,
when it has that hook). A kind added to the kind map is covered the day it is registered.

Each rule of the checker is shown to fail on a small figure that breaks it and to pass the same figure mended."""

from __future__ import annotations

import importlib
import struct

import networkx as nx
import numpy as np
import pytest
from matplotlib.figure import Figure
from matplotlib.tri import Triangulation

from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.kinds import KINDS
from tests.conftest import REPO
from tests.support.plots import (contrast_problems, contrast_ratio, empty_band_problems, figure_problems,
                                 text_problems, tolerance_problems)


def png_size(data: bytes) -> tuple[int, int]:
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    return struct.unpack(">II", data[16:24])


@pytest.mark.parametrize("kind", sorted(KINDS))
def test_every_png_of_the_example_passes_the_plot_checker(kind):
    spec = KINDS[kind]
    job_input = spec.input_of(spec.request_model.model_validate(spec.example()))
    solved = spec.solve(job_input, lambda *_: None)
    pngs = {a.name[:-4]: a for a in spec.render_artifacts(job_input, solved) if a.name.endswith(".png")}
    assert pngs, f"{kind} renders no plot"
    artifacts = importlib.import_module(f"plantsolve.solvers.{kind}.artifacts")
    figures = artifacts.figures(job_input, solved.result)
    assert set(figures) == set(pngs), "figures() names every PNG artifact by its stem"
    declared = artifacts.tolerances(job_input, solved.result) if hasattr(artifacts, "tolerances") else {}
    problems = []
    for stem, fig in figures.items():
        width, _ = png_size(pngs[stem].data)
        dpi = width / fig.get_figwidth()  # the resolution the artifact was saved at
        problems += [f"{kind}/{stem}.png: {p}" for p in figure_problems(fig, dpi, declared.get(stem, []))]
    assert not problems, "\n".join(problems)


# shipped example files whose plots differ in kind from the kind's example (a crowded graph)
SHIPPED = [("rigidity", "examples/rigidity/official_parts.ldr")]


@pytest.mark.parametrize("kind, path", SHIPPED)
def test_every_png_of_a_shipped_example_file_passes_the_plot_checker(kind, path):
    spec = KINDS[kind]
    source = StoredInput.from_path(REPO / path)
    job_input = spec.input_of(spec.parse_upload(source, None), source)
    solved = spec.solve(job_input, lambda *_: None)
    pngs = {a.name[:-4]: a for a in spec.render_artifacts(job_input, solved) if a.name.endswith(".png")}
    artifacts = importlib.import_module(f"plantsolve.solvers.{kind}.artifacts")
    declared = artifacts.tolerances(job_input, solved.result) if hasattr(artifacts, "tolerances") else {}
    problems = []
    for stem, fig in artifacts.figures(job_input, solved.result).items():
        dpi = png_size(pngs[stem].data)[0] / fig.get_figwidth()
        problems += [f"{path} {stem}.png: {p}" for p in figure_problems(fig, dpi, declared.get(stem, []))]
    assert not problems, "\n".join(problems)


def test_the_text_checker_sees_a_title_in_a_colour_bar_small_text_and_a_hidden_z_label():
    fig = Figure(figsize=(6.4, 5.6))
    ax = fig.add_subplot()
    image = ax.imshow([[0, 1], [1, 0]])
    fig.colorbar(image, ax=ax, label="W [-]")
    ax.set(xlabel="x [mm]", ylabel="y [mm]", title="a long title that runs on into the colour bar on its right")
    ax.text(0.5, 0.5, "tiny", fontsize=6)
    problems = text_problems(fig, 100)
    assert any("runs into a colour bar" in p for p in problems), problems
    assert any("'tiny' is 6 pt" in p for p in problems), problems

    fig = Figure(figsize=(8.4, 4.6), layout="constrained")
    for k in (1, 2):  # two 3-D panels side by side: the left one's z label lies under the right one
        ax = fig.add_subplot(1, 2, k, projection="3d")
        ax.set(xlabel="x [m]", ylabel="y [m]", zlabel="z [m]")
    problems = text_problems(fig, 100)
    assert any("'z [m]'" in p and "runs into" in p for p in problems), problems
    fig = Figure(figsize=(8.4, 4.0))
    ax = fig.add_subplot(projection="3d")
    ax.set(xlabel="x [m]", ylabel="y [m]")
    assert any("z label" in p for p in figure_problems(fig, 100))


def _graph(spread: float) -> Figure:
    """A networkx drawing with long node labels, its nodes ``spread`` apart (in a fixed view)."""
    fig = Figure(figsize=(5, 4))
    ax = fig.add_subplot()
    graph = nx.path_graph(["bracket_left", "bracket_right", "axle_long_part"])
    pos = {n: (k * spread, 0.0) for k, n in enumerate(graph.nodes)}
    nx.draw_networkx(graph, pos, ax=ax, font_size=9, node_size=30)
    ax.set(xlim=(-0.5, 2.5), ylim=(-1, 1), xlabel="x [-]", ylabel="y [-]")
    return fig


def test_the_text_checker_sees_node_labels_over_each_other():
    crowded = text_problems(_graph(0.15), 100)
    assert any("'bracket_left' overlaps text 'bracket_right'" in p for p in crowded), crowded
    assert not [p for p in text_problems(_graph(1.0), 100) if "overlaps text" in p]


def test_contrast_ratios_are_wcags():
    assert contrast_ratio((0, 0, 0), (1, 1, 1)) == pytest.approx(21.0)
    assert contrast_ratio((1, 1, 1), (1, 1, 1)) == pytest.approx(1.0)
    assert contrast_ratio((1.0, 0.498, 0.055), (1, 1, 1)) == pytest.approx(2.53, abs=0.01)  # matplotlib's orange
    assert contrast_ratio((0.4667, 0.4667, 0.4667), (1, 1, 1)) == pytest.approx(4.48, abs=0.02)  # #777 on white


def _labelled_map(colour: str, label_box: bool = False) -> Figure:
    """A filled map from dark purple (left) to yellow (right) with a label over each end."""
    fig = Figure(figsize=(5, 4))
    ax = fig.add_subplot()
    ax.imshow(np.tile(np.linspace(0, 1, 200), (100, 1)), cmap="viridis", extent=(0, 2, 0, 1), aspect="auto")
    box = {"facecolor": "black", "edgecolor": "none", "alpha": 0.8} if label_box else None
    ax.text(0.15, 0.5, "theta=0", color=colour, fontsize=10, bbox=box)
    ax.text(1.75, 0.5, "theta=5", color=colour, fontsize=10, bbox=box)
    ax.set(xlabel="flow [kg/s]", ylabel="pressure [-]")
    return fig


def test_the_contrast_checker_sees_text_lost_in_its_background():
    white = contrast_problems(_labelled_map("white"), 100)
    assert len(white) == 1 and "'theta=5'" in white[0] and "contrast ratio of 1." in white[0], white  # on yellow
    black = contrast_problems(_labelled_map("black"), 100)
    assert len(black) == 1 and "'theta=0'" in black[0], black  # on dark purple
    assert contrast_problems(_labelled_map("white", label_box=True), 100) == []  # its own dark box under it
    fig = Figure(figsize=(4, 3))
    ax = fig.add_subplot()
    ax.plot([0, 1], [0, 1])
    ax.text(0.1, 0.8, "phi=0.9", color="tab:orange")
    ax.set(xlabel="x [-]", ylabel="y [-]")
    assert ["'phi=0.9'" in p for p in contrast_problems(fig, 100)] == [True]
    ax.texts[0].set_color("#a04000")  # a darker orange reads
    assert contrast_problems(fig, 100) == []


def _weight_map(reach: float) -> Figure:
    """Filled contours over a disk of radius ``reach`` inside a drawn wall of radius 1 (a pipe's cross-section)."""
    fig = Figure(figsize=(5, 4.6))
    ax = fig.add_subplot()
    r, t = np.meshgrid(np.linspace(0, reach, 30), np.linspace(0, 2 * np.pi, 90, endpoint=False))
    x, y = np.append((r * np.cos(t)).ravel(), 0), np.append((r * np.sin(t)).ravel(), 0)
    ax.tricontourf(Triangulation(x, y), x ** 2 + y, levels=12)
    wall = np.linspace(0, 2 * np.pi, 400)
    ax.plot(np.cos(wall), np.sin(wall), color="0.3", lw=1)
    ax.set(xlabel="x [mm]", ylabel="y [mm]", aspect="equal", xlim=(-1.1, 1.1), ylim=(-1.1, 1.1))
    return fig


def test_the_band_checker_sees_data_that_stops_short_of_its_outline():
    short = empty_band_problems(_weight_map(0.95), 100)
    assert len(short) == 1 and "stops short of the closed line" in short[0], short
    width = float(short[0].split("about ")[1].split(" ")[0])
    assert 0.03 < width < 0.08, short  # the 0.05 ring, in data units (less the wall's stroke)
    assert empty_band_problems(_weight_map(1.0), 100) == []
    fig = Figure(figsize=(5, 4))
    ax = fig.add_subplot()
    values = np.tile(np.linspace(0, 1, 40), (30, 1))
    values[:, :6] = np.nan  # the image's first columns: no data
    image = ax.imshow(values, extent=(0, 4, 0, 3), aspect="auto")
    ax.set(xlabel="x [mm]", ylabel="y [mm]")
    assert [p.split(":")[1].strip()[:40] for p in empty_band_problems(fig, 100)] == [
        "the filled data stops short of the image"]
    values[:, :6] = 0.5
    image.set_data(values)
    assert empty_band_problems(fig, 100) == []


def _deviations(band: tuple[float, float] | None) -> Figure:
    fig = Figure(figsize=(5, 3))
    ax = fig.add_subplot()
    ax.plot([1, 2, 3, 4], [0.2, -0.4, 0.7, 0.1], "o")
    if band is not None:
        ax.axhspan(*band, color="tab:green", alpha=0.2)
    ax.set(xlabel="bend [-]", ylabel="angle deviation [deg]", title="angle")
    return fig


def test_the_tolerance_checker_wants_a_band_for_each_declared_tolerance():
    declared = [{"axes": "angle", "axis": "y", "band": (-0.5, 0.5)}]
    missing = tolerance_problems(_deviations(None), declared)
    assert missing == ["axes 'angle': the tolerance -0.5 to 0.5 on y is drawn as no band"]
    assert tolerance_problems(_deviations((-1.0, 1.0)), declared) == missing  # a band, but not the tolerance's
    assert tolerance_problems(_deviations((-0.5, 0.5)), declared) == []
    fig = _deviations(None)
    ax = fig.axes[0]
    ax.fill_between([0.5, 4.5], -0.5, 0.5, alpha=0.2)  # fill_between draws it too
    assert tolerance_problems(fig, declared) == []
    assert tolerance_problems(fig, [{"axes": "rotation", "band": (-1, 1)}]) == [
        "no axes 'rotation' for the tolerance -1 to 1"]
