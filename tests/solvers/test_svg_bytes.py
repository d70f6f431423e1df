"""The same figure gives the same SVG bytes (an artifact's SHA-256 names its content, not the save), and the salt
that makes the element ids repeatable does not stay behind in matplotlib's settings."""

from __future__ import annotations

import matplotlib
import numpy as np
from matplotlib.figure import Figure

from plantsolve.solvers.plots import figure_artifacts, figure_bytes


def _figure(scale: float = 1.0) -> Figure:
    fig = Figure(figsize=(4, 3))
    ax = fig.add_subplot()
    x = np.linspace(0.0, 1.0, 20)
    ax.plot(x, scale * x**2, label="flow")
    ax.fill_between(x, 0.0, scale * x, alpha=0.3, hatch="//")
    image = ax.imshow(np.arange(12.0).reshape(3, 4) * scale, extent=(0, 1, 0, 1))
    fig.colorbar(image, ax=ax, label="efficiency [-]")
    ax.legend()
    ax.set_xlabel("x [mm]")
    return fig


def test_the_same_figure_saved_twice_is_the_same_svg():
    first = {a.name: a.data for a in figure_artifacts("map", _figure())}
    second = {a.name: a.data for a in figure_artifacts("map", _figure())}
    assert first["map.svg"] == second["map.svg"]
    assert first["map.png"] == second["map.png"]
    assert b"<clipPath" in first["map.svg"]  # ids that matplotlib hashes are in the file


def test_another_figure_is_another_svg():
    assert figure_bytes(_figure(1.0), "svg") != figure_bytes(_figure(2.0), "svg")


def test_the_salt_is_not_left_in_matplotlibs_settings():
    before = matplotlib.rcParams["svg.hashsalt"]
    figure_bytes(_figure(), "svg")
    assert matplotlib.rcParams["svg.hashsalt"] == before
