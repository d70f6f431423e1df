"""Checks every plot of every kind must pass: labelled axes with a unit in brackets, and legends that hide
no data (no plotted point under a legend; a figure legend outside every axes)."""

from __future__ import annotations

import re

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

UNIT = re.compile(r"\[[^\[\]]+\]")


def _is_colorbar(ax) -> bool:
    return ax.get_label() == "<colorbar>"


def _is_twin_of(ax, others) -> str | None:
    """'x' when ax shares its x axis with another axes (a twinx), 'y' for a twiny."""
    for o in others:
        if o is ax:
            continue
        if ax.get_shared_x_axes().joined(ax, o) and ax.bbox.bounds == o.bbox.bounds:
            return "x"
        if ax.get_shared_y_axes().joined(ax, o) and ax.bbox.bounds == o.bbox.bounds:
            return "y"
    return None


def axis_problems(fig: Figure) -> list[str]:
    """Every visible axes: x and y labels (z too in 3-D) non-empty with a unit in brackets; a twin axes needs
    only its own axis labelled; a colour bar its long axis."""
    problems = []
    axes = [ax for ax in fig.axes if ax.get_visible()]
    for ax in axes:
        name = ax.get_title() or ax.get_label() or repr(ax)
        if _is_colorbar(ax):
            label = ax.get_ylabel() or ax.get_xlabel()
            if not UNIT.search(label or ""):
                problems.append(f"colour bar of {name!r}: label {label!r} has no unit in brackets")
            continue
        if not ax.axison:
            continue
        twin = _is_twin_of(ax, axes)
        wanted = ["y"] if twin == "x" else ["x"] if twin == "y" else ["x", "y"]
        if ax.name == "3d":
            wanted.append("z")
        for axis in wanted:
            if axis == "x" and not ax.get_xticks().size and not ax.get_xlabel():
                continue
            if axis == "x" and not ax.get_xlabel() and any(
                    UNIT.search(o.get_xlabel()) for o in ax.get_shared_x_axes().get_siblings(ax) if o is not ax):
                continue  # stacked panels sharing x: the bottom one names it
            label = getattr(ax, f"get_{axis}label")()
            if not UNIT.search(label or ""):
                problems.append(f"axes {name!r}: {axis} label {label!r} has no unit in brackets")
    return problems


def _data_points(ax) -> np.ndarray:
    pts = []
    for line in ax.get_lines():
        xy = np.asarray(line.get_xydata(), dtype=float)
        xy = xy[np.all(np.isfinite(xy), axis=1)]
        if not len(xy):
            continue
        d = ax.transData.transform(xy)
        pts.append(d)
        if line.get_linestyle() not in ("None", "", " ") and len(d) > 1:  # the segments too, not only vertices
            s = np.linspace(0.0, 1.0, 64)[1:-1, None, None]
            pts.append((d[:-1][None] * (1 - s) + d[1:][None] * s).reshape(-1, 2))
    for coll in ax.collections:
        offs = np.asarray(coll.get_offsets(), dtype=float)
        if offs.size and len(offs) > 1:
            pts.append(coll.get_offset_transform().transform(offs))
    return np.concatenate(pts) if pts else np.zeros((0, 2))


def legend_problems(fig: Figure) -> list[str]:
    """No plotted point (line vertex or scatter marker) of any axes lies under a legend, and a figure
    legend does not overlap any axes."""
    FigureCanvasAgg(fig).draw()
    renderer = fig.canvas.get_renderer()
    problems = []
    legends = [(lg, None) for lg in fig.legends]
    legends += [(ax.get_legend(), ax) for ax in fig.axes if ax.get_legend() is not None]
    data_axes = [ax for ax in fig.axes if ax.get_visible() and not _is_colorbar(ax) and ax.name != "3d"]
    for lg, owner in legends:
        box = lg.get_window_extent(renderer)
        for ax in data_axes:
            pts = _data_points(ax)
            inside = ((pts[:, 0] > box.x0) & (pts[:, 0] < box.x1) & (pts[:, 1] > box.y0) & (pts[:, 1] < box.y1))
            if inside.any():
                problems.append(f"legend of {owner.get_title() if owner else 'the figure'!r} hides "
                                f"{int(inside.sum())} plotted point(s) of axes {ax.get_title()!r}")
            if owner is None and box.overlaps(ax.get_window_extent(renderer)):
                problems.append(f"figure legend overlaps axes {ax.get_title()!r}")
    return problems


def check_figure(fig: Figure) -> None:
    problems = axis_problems(fig) + legend_problems(fig)
    assert not problems, "\n".join(problems)
