"""Plots of a perfmap result (PNG and SVG): characteristics, envelopes, performance map."""

from __future__ import annotations

import io
import math

import numpy as np
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator  # no pyplot: no global figure state; PNG/SVG via Agg/SVG

from plantsolve.schemas.perfmap import PerfmapRequest, PerfmapResult
from plantsolve.solvers.base import Artifact
from plantsolve.solvers.perfmap.families import curveset_from_fits

_SMALL_MULTIPLES_MAX = 36
_MEDIA = {"png": "image/png", "svg": "image/svg+xml"}


def _save(fig: Figure, stem: str) -> list[Artifact]:
    out = []
    for fmt in ("png", "svg"):
        buf = io.BytesIO()
        fig.savefig(buf, format=fmt, dpi=110,
                    metadata={"Date": None} if fmt == "svg" else None)
        out.append(Artifact(name=f"{stem}.{fmt}", media_type=_MEDIA[fmt], data=buf.getvalue()))
    return out


def _measured(request: PerfmapRequest):
    return {tuple(float(v) for v in request.setting_values(i)): p for i, p in enumerate(request.positions)}


def _values(s) -> tuple[float, ...]:
    return tuple(s.setting) if s.setting else (s.theta, s.phi)


SYMBOLS = {"theta": "θ", "phi": "φ"}


def _names(result: PerfmapResult) -> list[str]:
    """Axis labels of the setting parameters: name (θ/φ for the paper's) and unit."""
    units = result.setting_units or [""] * len(result.setting_names)
    return [SYMBOLS.get(n, n) + (f" [{u}]" if u else "") for n, u in zip(result.setting_names, units)]


def _label(result: PerfmapResult, values) -> str:
    return ", ".join(f"{SYMBOLS.get(n, n)}={v:g}" for n, v in zip(result.setting_names, values))


def _characteristics(request: PerfmapRequest, result: PerfmapResult) -> Figure:
    curves = curveset_from_fits(result.settings)
    # denser towards choke (t = 1), where a parabola_log efficiency falls steeply
    t = 1.0 - (1.0 - np.linspace(0.0, 1.0, 161)) ** 2
    X, Y, E = curves.sample(t)
    meas = _measured(request)
    n = len(result.settings)
    if n <= _SMALL_MULTIPLES_MAX:
        cols = math.ceil(math.sqrt(n))
        rows = math.ceil(n / cols)
        # A fixed grid layout: constrained layout with ~2n axes (twin y axes) is very slow.
        fig = Figure(figsize=(3.4 * cols, 2.7 * rows + 0.6))
        axes = fig.subplots(rows, cols, squeeze=False).ravel()
        fig.subplots_adjust(left=0.05, right=0.95, bottom=0.05, top=1 - 0.7 / (2.7 * rows + 0.6),
                            hspace=0.45, wspace=0.45)
        for k, s in enumerate(result.settings):
            ax = axes[k]
            p = meas.get(_values(s))
            ax.plot(X[k], Y[k], "C0-", lw=1.5)
            ax2 = ax.twinx()
            ax2.plot(X[k], E[k], "C1--", lw=1.2)
            if p is not None:
                ax.plot(p.flow, p.pressure, "C0o", ms=3.5)
                ax2.plot(p.flow, p.efficiency, "C1^", ms=3.5)
            ax.set_title(f"{_label(result, _values(s))}  (y {100 * s.pressure_max_rel_error:.1f}%,"
                         f" η {100 * s.efficiency_max_rel_error:.1f}%)", fontsize=8)
            ax.tick_params(labelsize=7)
            ax2.tick_params(labelsize=7, colors="C1")
        for ax in axes[n:]:
            ax.set_visible(False)
        eff = ", ".join(sorted({s.efficiency_family for s in result.settings}))
        fig.suptitle(f"Characteristics (pressure {result.family}, efficiency {eff}, "
                     f"{result.fit}): pressure (blue, left) "
                     "and efficiency (orange, right) vs flow; markers = measured")
        return fig
    fig = Figure(figsize=(12, 5), layout="constrained")
    ax1, ax2 = fig.subplots(1, 2)
    for k, s in enumerate(result.settings):
        col = f"C{k % 10}"
        ax1.plot(X[k], Y[k], "-", color=col, lw=1)
        ax2.plot(X[k], E[k], "-", color=col, lw=1)
        p = meas.get(_values(s))
        if p is not None:
            ax1.plot(p.flow, p.pressure, "o", color=col, ms=2.5)
            ax2.plot(p.flow, p.efficiency, "o", color=col, ms=2.5)
    ax1.set(xlabel="flow", ylabel="pressure", title="Characteristics")
    ax2.set(xlabel="flow", ylabel="efficiency", title="Efficiency")
    return fig


def _envelopes(result: PerfmapResult) -> Figure:
    curves = curveset_from_fits(result.settings)
    X, Y, _ = curves.sample(np.linspace(0.0, 1.0, 101))
    fig = Figure(figsize=(12, 5), layout="constrained")
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
        ax2.plot(env.flow, env.efficiency, "-", color=col, lw=1.8, label=f"η, {tag}")
    per = f" per {', '.join(names[:-1])}" if fixed_names else ""
    ax1.set(xlabel="flow", ylabel="pressure", title=f"Max-curves (envelopes){per} over {names[-1]}")
    ax1.legend(fontsize=8)
    ax2.set(xlabel="flow", ylabel="efficiency along the max-curve")
    ax3 = ax2.twinx()
    for j, env in enumerate(result.envelopes):
        ax3.plot(env.flow, env.phi, ":", color=f"C{j % 10}", lw=1.5)
    ax3.set_ylabel(f"{names[-1]} on the max-curve (dotted)")
    ax2.legend(fontsize=8, loc="lower center")
    if not result.envelopes:
        ax1.text(0.5, 0.5, "no envelopes", transform=ax1.transAxes, ha="center")
    return fig


# contour colour and style of the optimal setting parameters (1, 2 or 3 of them)
CONTOUR_STYLES = ([("orange", "-")], [("white", "--"), ("orange", "-")],
                  [("white", "--"), ("pink", ":"), ("orange", "-")])


def _map(result: PerfmapResult) -> Figure:
    fig = Figure(figsize=(12, 7.5), layout="constrained")
    ax, ax_tri = fig.subplots(1, 2, width_ratios=[4.2, 1])
    _triangulation(ax_tri, result)
    m = result.map
    curves = curveset_from_fits(result.settings)
    X, Y, _ = curves.sample(np.linspace(0.0, 1.0, 101))
    if m is None:
        for k in range(len(result.settings)):
            ax.plot(X[k], Y[k], "k-", lw=0.8)
        ax.set(xlabel="flow", ylabel="pressure", title="Characteristics (no map requested)")
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
        cf = ax.contourf(gx, gy, np.ma.masked_invalid(eta), levels=levels, cmap="viridis")
        fig.colorbar(cf, ax=ax, label="max efficiency η")
        for grid, name, (colour, style) in zip(grids, names, CONTOUR_STYLES[len(grids) - 1]):
            if np.nanmax(grid) > np.nanmin(grid):
                cs = ax.contour(gx, gy, np.ma.masked_invalid(grid), levels=8, colors=colour, linewidths=1.0,
                                linestyles=style)
                ax.clabel(cs, fontsize=7, fmt=f"{name.split(' [')[0]}=%.3g")
        ax.contour(gx, gy, finite.astype(float), levels=[0.5], colors="red", linewidths=1.5)
    for k in range(len(result.settings)):
        ax.plot(X[k], Y[k], "k-", lw=0.6, alpha=0.7)
    _limit_lines(ax, result)
    ax.plot([], [], "k-", lw=0.6, label="setting characteristics")
    for name, (colour, style) in zip(names, CONTOUR_STYLES[len(names) - 1]):
        ax.plot([], [], color=colour, linestyle=style, label=f"optimal {name}")
    ax.plot([], [], "r-", label="reachable boundary")
    ax.legend(fontsize=8, loc="upper right", facecolor="lightgrey")
    ax.set(xlabel="flow", ylabel="pressure",
           title=f"Performance map ({m.method}, {result.family}): "
           f"max efficiency and optimal ({', '.join(n.split(' [')[0] for n in names)})")
    return fig


def _limit_lines(ax, result: PerfmapResult) -> None:
    """Surge, choke and surge-margin lines, joined within each θ (one line per θ)."""
    styles = (("surge_line", "m-", 2.0, "surge line"), ("surge_margin_line", "m:", 1.5, "surge margin line"),
              ("choke_line", "c-", 2.0, "choke line"))
    for name, style, width, label in styles:
        points = getattr(result, name) or []
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


def render_artifacts(request: PerfmapRequest, result: PerfmapResult) -> list[Artifact]:
    """characteristics, envelopes and map, each as .png and .svg."""
    out = []
    for stem, fig in (("characteristics", _characteristics(request, result)),
                      ("envelopes", _envelopes(result)), ("map", _map(result))):
        out += _save(fig, stem)
    return out
