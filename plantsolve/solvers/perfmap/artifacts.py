"""Plots of a perfmap result (PNG and SVG): characteristics, envelopes, performance map; and its exports:
``map.csv`` (the max-efficiency grid), ``curves.csv`` (the fitted characteristics) and the cycle-code tables
on the beta grid (``map_pycycle.py``, ``map_gasturb.map``, ``map_beta.csv``), units in every axis label and
column header (the result's ``units``)."""

from __future__ import annotations

import csv
import io
import math

import numpy as np
from matplotlib import patheffects
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.ticker import MaxNLocator  # no pyplot: no global figure state; PNG/SVG via Agg/SVG
from scipy import ndimage

from plantsolve.schemas.perfmap import PerfmapRequest, PerfmapResult
from plantsolve.solvers.base import Artifact, Solved
from plantsolve.solvers.perfmap.cycle_exports import beta_csv, gasturb_tables, pycycle_module
from plantsolve.solvers.perfmap.families import curveset_from_fits
from plantsolve.solvers.perfmap.validation import PerfmapInput, loaded
from plantsolve.solvers.perfmap.performance_map import distance_to_region
from plantsolve.solvers.plots import figure_artifacts

_SMALL_MULTIPLES_MAX = 36
# the efficiency axis's colour: matplotlib's orange (C1) is 2.5:1 on white, too faint for its tick labels
EFFICIENCY_COLOUR = "#b35806"


def _measured(request: PerfmapRequest):
    return {tuple(float(v) for v in request.setting_values(i)): p for i, p in enumerate(request.positions)}


def _values(s) -> tuple[float, ...]:
    return tuple(s.setting) if s.setting else (s.theta, s.phi)


SYMBOLS = {"theta": "θ", "phi": "φ"}


NOT_STATED = "(unit as in the file)"  # the request stated none: the values are in whatever unit the rig wrote


def _is_ratio(unit: str | None) -> bool:
    return unit in ("1", "-")


def _with_unit(name: str, unit: str | None) -> str:
    """'flow [kg/s]'; a dimensionless one '[-]'; one the request did not state 'flow (unit as in the file)'."""
    return f"{name} {NOT_STATED}" if not unit else f"{name} [{'-' if _is_ratio(unit) else unit}]"


def _units(result: PerfmapResult) -> dict:
    u = result.units
    return {"flow": u.flow if u else None, "pressure": u.pressure if u else None}


def quantity(result: PerfmapResult, quantity: str) -> str:
    """The quantity's name: a pressure whose unit is a ratio ('1', '-') is a pressure ratio."""
    return "pressure ratio" if quantity == "pressure" and _is_ratio(_units(result)["pressure"]) else quantity


def axis_label(result: PerfmapResult, quantity_name: str, text: str | None = None) -> str:
    """'flow [kg/s]', 'pressure ratio [-]', 'efficiency η [-]' (always a fraction in a result: a file's % is
    divided by 100 on reading); 'pressure (unit as in the file)' where the request stated no unit."""
    if quantity_name == "efficiency":
        return f"{text or 'efficiency η'} [-]"
    return _with_unit(text or quantity(result, quantity_name), _units(result)[quantity_name])


def _names(result: PerfmapResult) -> list[str]:
    """Axis labels of the setting parameters: name (θ/φ for the paper's) and unit."""
    units = result.setting_units or [""] * len(result.setting_names)
    return [_with_unit(SYMBOLS.get(n, n), u) for n, u in zip(result.setting_names, units)]


def _bare(label: str) -> str:
    """'θ' of 'θ [deg]' or of 'θ (unit as in the file)'."""
    return label.split(" [")[0].removesuffix(f" {NOT_STATED}")


def _label(result: PerfmapResult, values) -> str:
    return ", ".join(f"{SYMBOLS.get(n, n)}={v:g}" for n, v in zip(result.setting_names, values))


def _characteristics(request: PerfmapRequest, result: PerfmapResult) -> Figure:
    curves = curveset_from_fits(result.settings)
    # denser towards choke (t = 1), where a parabola_log efficiency falls steeply
    t = 1.0 - (1.0 - np.linspace(0.0, 1.0, 161)) ** 2
    X, Y, E = curves.sample(t)
    meas = _measured(request)
    n = len(result.settings)
    xlabel, ylabel, elabel = axis_label(result, "flow"), axis_label(result, "pressure"), axis_label(result, "efficiency")
    pname = quantity(result, "pressure")
    if n <= _SMALL_MULTIPLES_MAX:
        cols = math.ceil(math.sqrt(n))
        rows = math.ceil(n / cols)
        # A fixed grid layout: constrained layout with ~2n axes (twin y axes) is very slow.
        height = 2.9 * rows + 1.3
        fig = Figure(figsize=(3.9 * cols + 0.4, height))
        axes = fig.subplots(rows, cols, squeeze=False).ravel()
        fig.subplots_adjust(left=0.09 / cols ** 0.5, right=1 - 0.09 / cols ** 0.5, bottom=0.7 / height,
                            top=1 - 1.0 / height, hspace=0.62, wspace=0.62)
        for k, s in enumerate(result.settings):
            ax = axes[k]
            p = meas.get(_values(s))
            ax.plot(X[k], Y[k], "C0-", lw=1.5, label=f"{pname} (fit)")
            ax2 = ax.twinx()
            ax2.plot(X[k], E[k], "--", color=EFFICIENCY_COLOUR, lw=1.2, label="efficiency (fit)")
            if p is not None:
                ax.plot(p.flow, p.pressure, "C0o", ms=3.5, label=f"{pname} (measured)")
                ax2.plot(p.flow, p.efficiency, "^", color=EFFICIENCY_COLOUR, ms=3.5, label="efficiency (measured)")
            ax.set_xlabel(xlabel, fontsize=8)
            ax.set_ylabel(ylabel, fontsize=8, color="C0")
            ax2.set_ylabel(elabel, fontsize=8, color=EFFICIENCY_COLOUR)
            ax.tick_params(labelsize=8)
            ax2.tick_params(labelsize=8, colors=EFFICIENCY_COLOUR)
            ax.set_title(f"{_label(result, _values(s))}  (p {100 * s.pressure_max_rel_error:.1f}%,"
                         f" η {100 * s.efficiency_max_rel_error:.1f}%)", fontsize=8, **_title_place(ax, ax2))
        for ax in axes[n:]:
            ax.set_visible(False)
        fig.legend(handles=_legend_handles(pname), loc="lower center", ncol=4, fontsize=8, frameon=False)
        eff = ", ".join(sorted({s.efficiency_family for s in result.settings}))
        # two lines: on one, a narrow figure (few settings) cut it off at both edges
        fig.suptitle(f"Characteristics ({pname} {result.family}, efficiency {eff}, {result.fit})\n"
                     "panel titles: setting and max relative error", fontsize=11)
        return fig
    fig = Figure(figsize=(12, 5.4), layout="constrained")
    ax1, ax2 = fig.subplots(1, 2)
    for k, s in enumerate(result.settings):
        col = f"C{k % 10}"
        ax1.plot(X[k], Y[k], "-", color=col, lw=1)
        ax2.plot(X[k], E[k], "-", color=col, lw=1)
        p = meas.get(_values(s))
        if p is not None:
            ax1.plot(p.flow, p.pressure, "o", color=col, ms=2.5)
            ax2.plot(p.flow, p.efficiency, "o", color=col, ms=2.5)
    ax1.set(xlabel=xlabel, ylabel=ylabel, title=f"Characteristics ({n} settings)")
    ax2.set(xlabel=xlabel, ylabel=elabel, title="Efficiency")
    fig.legend(handles=[_line("fitted curve", "k"), _line("measured", "k", "", "o", ms=3)], loc="outside lower center",
               ncol=2, fontsize=8)
    return fig


def _title_place(*twins) -> dict:
    """``set_title``'s place for a panel whose axes (``twins``) write their ticks below and no offset or power of
    ten above a y axis: on the axes' top edge, where matplotlib's automatic placement leaves it then. Asking it
    measures every tick label of both y axes at each save (a fifth of the characteristics' CPU with 18 panels);
    a panel with an offset text keeps the automatic placement, which lifts the title over it."""
    for ax in twins:
        formatter = ax.yaxis.get_major_formatter()
        formatter.set_locs(ax.yaxis.get_majorticklocs())
        if formatter.get_offset() or ax.xaxis.get_ticks_position() != "bottom" or ax.xaxis.get_label_position() == "top":
            return {}
    return {"y": 1.0}


def _line(label: str, color: str, linestyle: str = "-", marker: str = "", **kw) -> Line2D:
    """A legend entry without data: a line, or with no linestyle a marker alone (as ``plot``'s 'ko'). Made bare:
    a throwaway figure's axes to plot it on cost more than the whole legend."""
    return Line2D([], [], label=label, color=color, linestyle=linestyle or "none", marker=marker or "none", **kw)


def _legend_handles(pname: str = "pressure"):
    return [_line(f"{pname} (fit, left axis)", "C0"), _line(f"{pname} (measured)", "C0", "", "o", ms=3.5),
            _line("efficiency (fit, right axis)", EFFICIENCY_COLOUR, "--"),
            _line("efficiency (measured)", EFFICIENCY_COLOUR, "", "^", ms=3.5)]


def _envelopes(result: PerfmapResult) -> Figure:
    curves = curveset_from_fits(result.settings)
    X, Y, _ = curves.sample(np.linspace(0.0, 1.0, 101))
    fig = Figure(figsize=(12, 5.8), layout="constrained")
    ax1, ax2 = fig.subplots(1, 2)
    names = _names(result)
    fixed_names = result.setting_names[:-1]
    for j, env in enumerate(result.envelopes):
        col = f"C{j % 10}"
        fixed = tuple(env.fixed) if env.fixed or not fixed_names else (env.theta,)
        for k, s in enumerate(result.settings):
            if _values(s)[:-1] == fixed:
                ax1.plot(X[k], Y[k], "-", color=col, lw=0.7, alpha=0.6)
        tag = ", ".join(f"{SYMBOLS.get(n, n)}={v:g}" for n, v in zip(fixed_names, fixed)) or "max-curve"
        ax1.plot(env.flow, env.pressure, "-", color=col, lw=2.2, label=tag)
        ax2.plot(env.flow, env.efficiency, "-", color=col, lw=1.8)
    per = f" per {', '.join(names[:-1])}" if fixed_names else ""
    ax1.set(xlabel=axis_label(result, "flow"), ylabel=axis_label(result, "pressure"),
            title=f"Max-curves (envelopes){per} over {names[-1]}")
    ax2.set(xlabel=axis_label(result, "flow"), ylabel=axis_label(result, "efficiency", "efficiency along the max-curve"))
    ax3 = ax2.twinx()
    for j, env in enumerate(result.envelopes):
        ax3.plot(env.flow, env.phi, ":", color=f"C{j % 10}", lw=1.5)
    ax3.set_ylabel(f"{names[-1]} on the max-curve (dotted)")
    handles = [h for h in ax1.get_lines() if not h.get_label().startswith("_")]
    handles += [_line("thin: characteristics", "k", lw=0.7), _line(f"dotted: {names[-1]} (right axis)", "k", ":")]
    fig.legend(handles=handles, loc="outside lower center", ncol=min(len(handles), 6), fontsize=8)
    if not result.envelopes:
        ax1.text(0.5, 0.5, "no envelopes", transform=ax1.transAxes, ha="center")
    return fig


# contour colour and style of the optimal setting parameters (1, 2 or 3 of them)
CONTOUR_STYLES = ([("orange", "-")], [("white", "--"), ("orange", "-")],
                  [("white", "--"), ("pink", ":"), ("orange", "-")])
# Their labels: a dark shade of the line's colour on a light box, readable on every colour of the map (orange or
# white text straight on viridis' yellow was not); the lines get a dark edge for the same reason.
LABEL_COLOURS = {"orange": "#7a3e00", "white": "black", "pink": "#8b1a4a"}
LABEL_BOX = {"boxstyle": "round,pad=0.15", "facecolor": "white", "edgecolor": "none", "alpha": 0.9}
_REFINE = 4  # contour grids are refined this many times per map cell
_BOUNDARY_NODES = 160  # nodes per axis of the distance field the reachable boundary is drawn from
_BAND_CHUNK = 500  # band nodes per call of the distance to the region


def setting_levels(values: np.ndarray):
    """Contour levels of an optimal setting: with few distinct measured values (an IGV at 0 and 5 deg) the
    midpoints between them — where the optimum passes from one measured setting's side to the next —
    since levels in between would trace the interpolation's detail; otherwise 8 levels."""
    distinct = np.unique(values)
    if 2 <= len(distinct) <= 4:
        return ((distinct[:-1] + distinct[1:]) / 2).tolist()
    return 8


def smooth_on_finer_grid(gx: np.ndarray, gy: np.ndarray, z: np.ndarray, sigma: float = 0.8):
    """A map field (NaN where unreachable) smoothed by a normalised Gaussian convolution (NaNs neither
    spread nor pull values to zero) and resampled on a grid ``_REFINE`` times finer: contours of an
    optimum that switches between neighbouring triangles from node to node then follow its trend instead
    of the grid's cells. Nodes of the finer grid whose nearest map node is unreachable stay NaN."""
    ok = np.isfinite(z)
    if sigma > 0:
        w = ndimage.gaussian_filter(ok.astype(float), sigma, mode="nearest")
        v = ndimage.gaussian_filter(np.where(ok, z, 0.0), sigma, mode="nearest")
        z = np.where(ok, v / np.maximum(w, 1e-12), np.nan)
    fx = np.linspace(gx[0], gx[-1], (len(gx) - 1) * _REFINE + 1)
    fy = np.linspace(gy[0], gy[-1], (len(gy) - 1) * _REFINE + 1)
    fine = resample(gx, gy, z, fx, fy)
    i = np.rint(np.interp(fx, gx, np.arange(len(gx)))).astype(int)
    j = np.rint(np.interp(fy, gy, np.arange(len(gy)))).astype(int)
    return fx, fy, np.where(ok[np.ix_(j, i)], fine, np.nan)


def resample(gx: np.ndarray, gy: np.ndarray, z: np.ndarray, fx: np.ndarray, fy: np.ndarray) -> np.ndarray:
    """z (NaN where unreachable) linearly interpolated at the nodes (fx x fy); NaNs first take their nearest
    reachable node's value, so that the edge of the region keeps its colour up to the smooth boundary."""
    ok = np.isfinite(z)
    if not ok.any():
        return np.full((len(fy), len(fx)), np.nan)
    idx = ndimage.distance_transform_edt(~ok, return_distances=False, return_indices=True)
    filled = z[tuple(idx)]
    ci = np.interp(fx, gx, np.arange(len(gx)))
    cj = np.interp(fy, gy, np.arange(len(gy)))
    J, I = np.meshgrid(cj, ci, indexing="ij")
    return ndimage.map_coordinates(filled, [J, I], order=1, mode="nearest")


def reachable_boundary(result: PerfmapResult):
    """(fx, fy, d): the distance (range-normalised) from a fine grid of nodes to the reachable region
    (0 inside), whose contour at ``boundary_level(fx, fy)`` is the region's boundary drawn smoothly — the map's
    own grid only says reachable or not per node, and its 0/1 contour is a staircase. The distance is computed
    in the band of fine nodes within two map cells of the map's boundary; elsewhere the map's node decides
    (0 reachable, 1 not). Within the band it is exact wherever it is below ``boundary_cap(fx, fy)``, and 1
    beyond: what the drawing reads (see :func:`distance_near`)."""
    curves = curveset_from_fits(result.settings)
    lo_x, hi_x = result.flow_range
    lo_y, hi_y = result.pressure_range
    fx = np.linspace(lo_x, hi_x, _BOUNDARY_NODES)
    fy = np.linspace(lo_y, hi_y, _BOUNDARY_NODES)
    m = result.map
    gx, gy = np.array(m.flow), np.array(m.pressure)
    ok = np.isfinite(np.array(m.efficiency, dtype=float))
    edge = ok ^ ndimage.binary_erosion(ok, border_value=0) | ~ok ^ ndimage.binary_erosion(~ok, border_value=0)
    band = ndimage.binary_dilation(edge, iterations=2)
    i = np.clip(np.rint(np.interp(fx, gx, np.arange(len(gx)))).astype(int), 0, len(gx) - 1)
    j = np.clip(np.rint(np.interp(fy, gy, np.arange(len(gy)))).astype(int), 0, len(gy) - 1)
    J, I = np.meshgrid(j, i, indexing="ij")
    d = np.where(ok[J, I], 0.0, 1.0)
    near = band[J, I]
    t = np.linspace(0.0, 1.0, m.t_samples)
    tri = np.array(result.triangles, dtype=int).reshape(-1, 3)
    ranges = (lo_x, hi_x, lo_y, hi_y)

    def distance(x, y):
        # a few hundred points at a time: the distance's exact pass holds arrays per (point, nearby block), which
        # for the whole band at once were a quarter of a GiB
        return np.concatenate([distance_to_region(curves, tri, t, x[k:k + _BAND_CHUNK], y[k:k + _BAND_CHUNK], ranges)
                               for k in range(0, len(x), _BAND_CHUNK)] or [[]])

    exact = distance_near(distance, fx, fy, near, boundary_cap(fx, fy))
    d[near] = exact[near]
    return fx, fy, d


def _cell(fx: np.ndarray, fy: np.ndarray) -> float:
    """The larger side of a cell of the (fx x fy) grid in range-normalised units."""
    return max((fx[1] - fx[0]) / (fx[-1] - fx[0]), (fy[1] - fy[0]) / (fy[-1] - fy[0]))


def boundary_level(fx: np.ndarray, fy: np.ndarray) -> float:
    """The distance to the region at which the boundary is drawn: a quarter of a fine cell."""
    return 0.25 * _cell(fx, fy)


def boundary_cap(fx: np.ndarray, fy: np.ndarray) -> float:
    """Beyond this distance a node's value changes nothing drawn: the distance is 1-Lipschitz, so a node further
    than the level plus a cell's diagonal has every neighbour beyond the level (no cell of it crosses the boundary
    contour, and the filled map masks it either way). A hair over, for rounding."""
    return (boundary_level(fx, fy) + math.sqrt(2.0) * _cell(fx, fy)) * (1 + 1e-6)


def distance_near(distance, fx: np.ndarray, fy: np.ndarray, wanted: np.ndarray, cap: float) -> np.ndarray:
    """``distance(x, y)`` (range-normalised, 1-Lipschitz) at the ``wanted`` nodes of the grid (fx x fy) where it
    is at most ``cap``; 1 at every other node. Quadtree: the distance at a block's centre less the block's
    half-diagonal bounds every node of the block from below, so a block whose bound exceeds ``cap`` is left out
    whole and the others are split in four, down to single nodes. Only the nodes near the region are evaluated
    one by one (the band of a coarse map is mostly far from it)."""
    ny, nx = wanted.shape
    hx, hy = 1.0 / (len(fx) - 1), 1.0 / (len(fy) - 1)  # a cell in range-normalised units
    counts = np.zeros((ny + 1, nx + 1), dtype=int)  # summed-area table: wanted nodes in a block in O(1)
    counts[1:, 1:] = wanted.cumsum(0).cumsum(1)
    out = np.ones(wanted.shape)
    side = 1 << max(0, math.ceil(math.log2(max(nx, ny))) - 3)  # 8 x 8 blocks to begin with
    blocks = [(j, i) for j in range(0, ny, side) for i in range(0, nx, side)]
    while blocks:
        blocks = [(j, i) for j, i in blocks if counts[min(j + side, ny), min(i + side, nx)] - counts[j, min(i + side, nx)]
                  - counts[min(j + side, ny), i] + counts[j, i] > 0]
        if not blocks:
            break
        b = np.array(blocks)
        # the centre of each block's nodes (a block at the grid's far edge is cut short there)
        cj = (b[:, 0] + np.minimum(b[:, 0] + side, ny) - 1) / 2
        ci = (b[:, 1] + np.minimum(b[:, 1] + side, nx) - 1) / 2
        dc = distance(np.interp(ci, np.arange(nx), fx), np.interp(cj, np.arange(ny), fy))
        if side == 1:
            out[b[:, 0], b[:, 1]] = np.where(dc <= cap, dc, 1.0)
            break
        reach = math.hypot((side - 1) / 2 * hx, (side - 1) / 2 * hy) * (1 + 1e-9)
        half = side // 2
        blocks = [(j + dj, i + di) for (j, i), lower in zip(blocks, dc - reach) if lower <= cap
                  for dj in (0, half) for di in (0, half) if j + dj < ny and i + di < nx]
        side = half
    return out


def _map(result: PerfmapResult) -> Figure:
    fig = Figure(figsize=(12, 8.2), layout="constrained")
    ax, ax_tri = fig.subplots(1, 2, width_ratios=[4.2, 1])
    _triangulation(ax_tri, result)
    m = result.map
    curves = curveset_from_fits(result.settings)
    X, Y, _ = curves.sample(np.linspace(0.0, 1.0, 101))
    xlabel, ylabel = axis_label(result, "flow"), axis_label(result, "pressure")
    if m is None:
        for k in range(len(result.settings)):
            ax.plot(X[k], Y[k], "k-", lw=0.8)
        ax.set(xlabel=xlabel, ylabel=ylabel, title="Characteristics (no map requested)")
        fig.legend(handles=[_line("setting characteristics", "k")], loc="outside lower center", fontsize=8)
        return fig
    gx, gy = np.array(m.flow), np.array(m.pressure)
    eta = np.array(m.efficiency, dtype=float)
    grids = [np.array(g, dtype=float) for g in m.settings] if m.settings else [
        np.array(m.theta, dtype=float), np.array(m.phi, dtype=float)]
    names = _names(result)
    finite = np.isfinite(eta)
    if finite.sum() >= 4:
        lo, hi = np.nanmin(eta), np.nanmax(eta)
        levels = MaxNLocator(14).tick_values(lo, hi) if hi > lo else [lo, lo + 1e-9]
        bx, by, d = reachable_boundary(result)
        level = boundary_level(bx, by)
        # filled on the boundary's fine grid, so that the colours end at the smooth boundary too
        fine_eta = np.ma.masked_where(d > level, resample(gx, gy, eta, bx, by))
        cf = ax.contourf(bx, by, fine_eta, levels=levels, cmap="viridis")
        fig.colorbar(cf, ax=ax, label=axis_label(result, "efficiency", "max efficiency η"))
        measured = np.array([_values(s) for s in result.settings], dtype=float).reshape(len(result.settings), -1)
        for k, (grid, name, (colour, style)) in enumerate(zip(grids, names, CONTOUR_STYLES[len(grids) - 1])):
            if np.nanmax(grid) > np.nanmin(grid) and len(gx) > 2 and len(gy) > 2:
                fx, fy, fine = smooth_on_finer_grid(gx, gy, grid, sigma=1.2)
                cs = ax.contour(fx, fy, np.ma.masked_invalid(fine), levels=setting_levels(measured[:, k]),
                                colors=colour, linewidths=1.0, linestyles=style)
                cs.set_path_effects([patheffects.Stroke(linewidth=2.2, foreground="0.15"), patheffects.Normal()])
                for text in ax.clabel(cs, fontsize=8, fmt=f"{_bare(name)}=%.3g", colors=LABEL_COLOURS[colour]):
                    text.set_bbox(LABEL_BOX)
        ax.contour(bx, by, d, levels=[level], colors="red", linewidths=1.5)
    for k in range(len(result.settings)):
        ax.plot(X[k], Y[k], "k-", lw=0.6, alpha=0.7)
    _limit_lines(ax, result)
    handles = [_line("setting characteristics", "k", lw=0.6)]
    handles += [_line(f"optimal {name}", colour, style)
                for name, (colour, style) in zip(names, CONTOUR_STYLES[len(names) - 1])]
    handles += [_line("reachable boundary", "r")]
    handles += [h for h in ax.get_lines() if h.get_label() in ("surge line", "surge margin line", "choke line")]
    # below the axes: a legend inside would cover the reachable region it explains
    fig.legend(handles=handles, loc="outside lower center", ncol=4, fontsize=8, facecolor="lightgrey")
    ax.set(xlabel=xlabel, ylabel=ylabel,
           title=f"Performance map ({m.method}, {result.family}): "
           f"max efficiency and optimal ({', '.join(_bare(n) for n in names)})")
    return fig


def _limit_lines(ax, result: PerfmapResult) -> None:
    """Surge, choke and surge-margin lines, joined within each θ (one line per θ)."""
    styles = (("surge_line", "m-", 2.0, "surge line"), ("surge_margin_line", "m:", 1.5, "surge margin line"),
              ("choke_line", "c-", 2.0, "choke line"))
    for name, style, width, label in styles:
        points = [p for p in (getattr(result, name) or []) if p is not None]
        key = (lambda p: tuple(p.setting)) if points and points[0].setting else (lambda p: (p.theta, p.phi))
        for j, group in enumerate(sorted({key(p)[:-1] for p in points})):
            line = sorted((p for p in points if key(p)[:-1] == group), key=lambda p: key(p)[-1])
            ax.plot([p.flow for p in line], [p.pressure for p in line], style, lw=width,
                    label=label if j == 0 else None)
    for p in result.choke_line:
        if p.vertical_to is not None:
            ax.plot([p.flow, p.flow], [p.pressure, p.vertical_to], "c-", lw=2.0)


def _triangulation(ax, result: PerfmapResult) -> None:
    """The settings and their triangulation (paper Fig. 15)."""
    values = np.array([_values(s) for s in result.settings], dtype=float).reshape(len(result.settings), -1)
    names = _names(result)
    if values.shape[1] == 1:  # one parameter: the settings along it
        ax.plot(np.zeros(len(values)), values[:, 0], "k-o", ms=3, lw=0.7)
        # no x axis: the settings lie along one parameter (a label here was cut off at the figure's edge)
        ax.set(xticks=[], ylabel=names[0], title="settings")
    else:
        th, ph = values[:, 0], values[:, 1]
        if result.triangles and values.shape[1] == 2 and all(j != k for _, j, k in result.triangles):
            ax.triplot(th, ph, np.array(result.triangles), color="0.4", lw=0.7)
        elif result.triangles:
            for i, j, _ in result.triangles:
                ax.plot(th[[i, j]], ph[[i, j]], "-", color="0.4", lw=0.7)
        ax.plot(th, ph, "ko", ms=3)
        ax.set(xlabel=names[0], ylabel=names[1],
               title="settings" + (f" (projected; {names[2]} not shown)" if values.shape[1] == 3 else ""))
    ax.set_box_aspect(1.6)


def _csv_header(result: PerfmapResult, quantity: str) -> str:
    """A column header the upload parser reads back: 'flow [kg/s]', 'efficiency [-]'; no brackets for a unit
    the request did not state."""
    if quantity == "efficiency":
        return "efficiency [-]"
    unit = _units(result)[quantity]
    return quantity if not unit else f"{quantity} [{'-' if unit == '1' else unit}]"


def _setting_headers(result: PerfmapResult) -> list[str]:
    """'theta [deg]', a ratio 'Nc [-]' as every other dimensionless column and the plots' axes (a GasTurb map's
    speed, unit '1', was 'Nc [1]'); bare where the request stated no unit."""
    units = result.setting_units or [""] * len(result.setting_names)
    return [n + (f" [{'-' if _is_ratio(u) else u}]" if u else "") for n, u in zip(result.setting_names, units)]


def _to_csv(header: list[str], rows) -> bytes:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(header)
    for row in rows:
        w.writerow(["" if v is None else repr(float(v)) if isinstance(v, (float, np.floating)) else v for v in row])
    return buf.getvalue().encode()


def curves_csv(result: PerfmapResult, samples: int = 51) -> bytes:
    """The fitted characteristics (speed lines) sampled evenly in flow: one row per point, the setting
    values first — the layout of a rig table, so the file reads back as an upload."""
    curves = curveset_from_fits(result.settings)
    t = np.linspace(0.0, 1.0, samples)
    X, Y, E = curves.sample(t)
    header = _setting_headers(result) + ["t [-]", _csv_header(result, "flow"), _csv_header(result, "pressure"),
                                         _csv_header(result, "efficiency")]
    rows = ([*map(float, _values(s)), float(t[j]), float(X[k, j]), float(Y[k, j]), float(E[k, j])]
            for k, s in enumerate(result.settings) for j in range(samples))
    return _to_csv(header, rows)


def map_csv(result: PerfmapResult) -> bytes:
    """The max-efficiency map, one row per grid node (flow fastest), empty cells where no setting reaches."""
    m = result.map
    header = [_csv_header(result, "flow"), _csv_header(result, "pressure"), "max efficiency [-]"]
    header += [f"optimal {h}" for h in _setting_headers(result)]
    grids = m.settings or [m.theta, m.phi]
    rows = ([m.flow[i], m.pressure[j], m.efficiency[j][i], *(g[j][i] for g in grids)]
            for j in range(len(m.pressure)) for i in range(len(m.flow)))
    return _to_csv(header, rows)


def figures(value: PerfmapInput | PerfmapRequest, result: PerfmapResult) -> dict[str, Figure]:
    """Every plot of the result by artifact stem (tests read their axes); the measured points are drawn in the
    result's units (the loaded input's)."""
    return {"characteristics": _characteristics(loaded(value).internal, result), "envelopes": _envelopes(result),
            "map": _map(result)}


def render_artifacts(value: PerfmapInput | PerfmapRequest, solved: Solved) -> list[Artifact]:
    """characteristics, envelopes and map, each as .png and .svg; curves.csv and (with a map) map.csv."""
    result = solved.result
    out = []
    for stem, fig in figures(value, result).items():
        out += figure_artifacts(stem, fig)
    out.append(Artifact(name="curves.csv", media_type="text/csv", data=curves_csv(result)))
    if result.map is not None:
        out.append(Artifact(name="map.csv", media_type="text/csv", data=map_csv(result)))
    return out + cycle_code_artifacts(result)


def cycle_code_artifacts(result: PerfmapResult) -> list[Artifact]:
    """The beta-grid exports (:mod:`~plantsolve.solvers.perfmap.cycle_exports`): map_pycycle.py (a full
    alpha x speed grid only), map_gasturb*.map, map_beta.csv."""
    if result.beta_map is None:
        return []
    out = []
    module = pycycle_module(result)
    if module is not None:
        out.append(Artifact(name="map_pycycle.py", media_type="text/x-python", data=module))
    for name, data in gasturb_tables(result).items():
        out.append(Artifact(name=name, media_type="text/plain; charset=utf-8", data=data))
    flow = "corrected " + _csv_header(result, "flow")
    out.append(Artifact(name="map_beta.csv", media_type="text/csv", data=beta_csv(
        result, _setting_headers(result), flow, _csv_header(result, "pressure").replace("pressure [-]", "pressure ratio [-]"))))
    return out
