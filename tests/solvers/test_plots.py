"""Every plot of every kind passes the plot checker (tests/support/plots.py) as it is saved: each kind's
example is solved through its SPEC (input_of, solve, render_artifacts), and every PNG artifact's figure —
each kind's ``artifacts.figures(input, result)``, by artifact stem — is checked at the resolution the PNG
was saved at. A kind added to the kind map is covered the day it is registered."""

from __future__ import annotations

import importlib
import struct

import pytest
from matplotlib.figure import Figure

from plantsolve.solvers.kinds import KINDS
from tests.support.plots import figure_problems, text_problems


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
    figures = importlib.import_module(f"plantsolve.solvers.{kind}.artifacts").figures(job_input, solved.result)
    assert set(figures) == set(pngs), "figures() names every PNG artifact by its stem"
    problems = []
    for stem, fig in figures.items():
        width, _ = png_size(pngs[stem].data)
        dpi = width / fig.get_figwidth()  # the resolution the artifact was saved at
        problems += [f"{kind}/{stem}.png: {p}" for p in figure_problems(fig, dpi)]
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
