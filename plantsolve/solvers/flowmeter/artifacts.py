"""Plots and tables of a flowmeter result: W over the cross-section, the electrode current density,
the linearity curve (PNG), and W on a grid (CSV)."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure  # no pyplot: no global figure state
from matplotlib.lines import Line2D
from matplotlib.path import Path
from matplotlib.textpath import TextPath
from matplotlib.tri import Triangulation

from plantsolve.schemas.flowmeter import FlowmeterRequest, FlowmeterResult
from plantsolve.solvers.base import Artifact, Solved
from plantsolve.solvers.plots import figure_artifact, plain_decades, thin_labels


def glyph_marker(glyph: str) -> Path:
    """A marker drawn as a font's glyph ('↑'), centred: as ``marker="$\\uparrow$"`` looks, without mathtext (whose
    parser a job process builds first)."""
    path = TextPath((0, 0), glyph)
    lo, hi = path.vertices.min(axis=0), path.vertices.max(axis=0)
    return Path(path.vertices - (lo + hi) / 2, path.codes)


def weight_map(request: FlowmeterRequest, result: FlowmeterResult) -> Figure:
    grid = np.asarray(result.grid, dtype=float)
    radius, units = request.pipe.radius, request.units
    # fixed places (constrained layout's for the example): measuring every label for the layout, and again for the
    # labels' thinning, cost more than drawing the map
    fig = Figure(figsize=(6.4, 6.2))
    ax = fig.add_axes((0.0997, 0.0672, 0.7165, 0.9261))
    tri = Triangulation(grid[:, 0], grid[:, 1])
    # the point electrodes' W is unbounded at the wall: colour the central range
    lo, hi = np.percentile(grid[:, 2], [1, 99])
    filled = ax.tricontourf(tri, np.clip(grid[:, 2], lo, hi), levels=20, cmap="viridis")
    lines = ax.tricontour(tri, np.clip(grid[:, 2], lo, hi), levels=10, colors="k", linewidths=0.5)
    labels = ax.clabel(lines, fontsize=8, fmt="%.2f", inline=False)
    bar = fig.add_axes((0.852, 0.0672, 0.0449, 0.9261), label="<colorbar>")  # the label fig.colorbar(ax=) gives
    fig.colorbar(filled, cax=bar, label="weight function W [-]")
    t = np.linspace(0, 2 * np.pi, 400)
    ax.plot(radius * np.cos(t), radius * np.sin(t), color="0.3", lw=1)
    if request.electrodes.shape == "patch":
        beta = np.radians(request.electrodes.half_angle)
        arc = np.linspace(-beta, beta, 50)
        for sign in (1, -1):
            ax.plot(sign * radius * np.cos(arc), radius * np.sin(arc), color="red", lw=4)
    elif request.electrodes.shape == "button":
        r_e, l_e = request.electrodes.radius, request.electrodes.protrusion
        arc = np.linspace(-np.arcsin(min(r_e / radius, 1.0)), np.arcsin(min(r_e / radius, 1.0)), 50)
        for sign in (1, -1):
            ax.plot(sign * radius * np.cos(arc), radius * np.sin(arc), color="red", lw=4)
            if l_e > 0:  # the protruding cylinder's section at z = 0
                ax.fill([sign * radius * np.cos(arc[0]), sign * (radius - l_e), sign * (radius - l_e),
                         sign * radius * np.cos(arc[-1])], [-r_e, -r_e, r_e, r_e], color="red")
    else:
        ax.plot([radius, -radius], [0, 0], "o", color="red", ms=8)
    ax.annotate("", xy=(0, 0.6 * radius), xytext=(0, 0.2 * radius), arrowprops={"arrowstyle": "->", "color": "white"})
    # two lines: one line ran on into the colour bar
    ax.set(xlabel=f"x [{units}]", ylabel=f"y [{units}]", aspect="equal",
           title=f"W over the cross-section\nS = {result.sensitivity:.5f} ({result.method})")
    # below the axes: inside, the legend covered the contours near the wall
    fig.legend(handles=[Line2D([], [], color="red", lw=4, label="electrodes"),
                        Line2D([], [], color="0.3", marker=glyph_marker("\u2191"), lw=0, label="B along +y (white arrow)"),
                        Line2D([], [], color="k", lw=0.5, label="contours of W")],
               loc="lower center", ncol=3, fontsize=8)
    thin_labels(labels)
    return fig


def current_plot(request: FlowmeterRequest, result: FlowmeterResult) -> Figure:
    """The density across the electrode at z = 0 (with the 2-D equipotential density of the same
    half-angle for patches, scaled to the same integral across) and, from the integral equation, its
    map over the electrode."""
    data = np.asarray(result.electrode_current, dtype=float)
    grid = np.asarray(result.electrode_current_map, dtype=float)
    fig = Figure(figsize=(11.0 if len(grid) else 6.4, 4.2))
    ax = fig.add_subplot(1, 2 if len(grid) else 1, 1)
    order = np.argsort(data[:, 0])
    theta, j = data[order, 0], data[order, 1]
    ax.plot(theta, j, "o-", ms=3, label=f"electrode at +R ({'z = 0' if len(grid) else 'per unit length'}, {result.method})")
    e = request.electrodes
    if e.shape == "patch" and len(grid):
        beta = np.radians(e.half_angle)
        t = np.radians(theta)
        two_d = 1 / np.sqrt(np.sin(beta) ** 2 - np.sin(t) ** 2)
        # scale by the integral across (Chebyshev nodes: weights pi/n after the factor sqrt(beta^2 - t^2))
        smooth = np.sqrt(np.maximum(beta**2 - t**2, 0))
        two_d *= np.sum(j * smooth) / np.sum(two_d * smooth)
        ax.plot(theta, two_d, "--", color="0.4", label="2-D (full-length) density, same beta, same integral across")
    ax.set(xlabel="angle from the electrode centre theta [deg]",
           ylabel="j R²/I (finite electrodes), j R/I′ (full length) [-]",
           title="virtual current density across the electrode (total = 1)")
    ax.set_yscale("log")
    plain_decades(ax.yaxis)
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3, which="both")
    if len(grid):
        mx = fig.add_subplot(1, 2, 2)
        tri = Triangulation(grid[:, 0], grid[:, 1])
        level = np.log10(np.clip(grid[:, 2], np.min(grid[:, 2][grid[:, 2] > 0]), None))
        filled = mx.tricontourf(tri, level, levels=20, cmap="magma")
        fig.colorbar(filled, ax=mx, label="log10(j R²/I) [-]")
        mx.plot(grid[:, 0], grid[:, 1], ".", color="0.8", ms=1)
        # said in the title: a legend inside covered the points it explains
        mx.set(xlabel="theta [deg]", ylabel=f"z [{request.units}]",
               title="density over the electrode at +R\n(dots: Chebyshev points; edges singular)")
    fig.tight_layout()
    return fig


def linearity_plot(result: FlowmeterResult) -> Figure:
    fig = Figure(figsize=(6.4, 4.0))
    fig.subplots_adjust(left=0.12, bottom=0.1253, right=0.9935, top=0.9363)  # constrained layout's, less its cost
    ax = fig.add_subplot()
    re = [p.reynolds for p in result.linearity]
    s = [p.sensitivity for p in result.linearity]
    ax.semilogx(re, s, "o-", label="S(Re)")
    plain_decades(ax.xaxis)
    ax.axhline(result.sensitivity_first_order, color="0.5", ls="--", label="first order sin(beta)/beta")
    ax.set(xlabel="Reynolds number Re [-]", ylabel="sensitivity S [-]", title="linearity")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3, which="both")
    return fig


def figures(request: FlowmeterRequest, result: FlowmeterResult) -> dict[str, Figure]:
    """Every plot by artifact stem: ``weight_function``, and ``electrode_current``, ``linearity`` when the
    result has them."""
    out = {"weight_function": weight_map(request, result)}
    if result.electrode_current:
        out["electrode_current"] = current_plot(request, result)
    if result.linearity:
        out["linearity"] = linearity_plot(result)
    return out


def render_artifacts(request: FlowmeterRequest, solved: Solved) -> list[Artifact]:
    """weight_function.png, electrode_current.png, linearity.png (with Reynolds numbers), weight_grid.csv."""
    result = solved.result
    out = [figure_artifact(f"{stem}.png", fig) for stem, fig in figures(request, result).items()]
    rows = [f"x [{request.units}],y [{request.units}],W [-]"] + [f"{x:.9g},{y:.9g},{w:.9g}" for x, y, w in result.grid]
    out.append(Artifact(name="weight_grid.csv", media_type="text/csv", data=("\n".join(rows) + "\n").encode()))
    return out
