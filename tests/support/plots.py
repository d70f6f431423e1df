"""Checks every plot of every kind must pass: labelled axes with a unit in brackets (x, y and, in 3-D, z),
legends that hide no data (no plotted point under a legend; a figure legend outside every axes), text that
nothing hides (no text over another axes, such as a title running into a colour bar; no text over other text;
no text cut off at the figure's edge) and text large enough to read at the saved size."""

from __future__ import annotations

import re

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.text import Text
from matplotlib.ticker import FixedLocator
from matplotlib.transforms import Bbox

# a unit in brackets, or the plain statement that the values are in the submitted file's (unstated) unit
UNIT = re.compile(r"\[[^\[\]]+\]|\(unit as in the file\)")


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


def _categorical(axis) -> bool:
    """Ticks at fixed places named by words (entity types, bend numbers are numbers): a categorical axis."""
    if not isinstance(axis.get_major_locator(), FixedLocator):
        return False
    names = [t.get_text().replace("\u2212", "-") for t in axis.get_ticklabels()]
    return any(n and not re.fullmatch(r"[-+0-9.,eE%]+", n) for n in names)


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
        # a 3-D axes keeps its 2-D frame off (axison False) and draws its three axes while _axis3don
        if not (ax._axis3don if ax.name == "3d" else ax.axison):
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
            if _categorical(getattr(ax, f"{axis}axis")) and label.strip():
                continue  # a categorical axis (ticks named, e.g. entity types) has a name and no unit
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


# 8 pt at 100 dpi (matplotlib's and a common screen's resolution): the smallest text, in pixels of the saved image,
# that reads without zooming. A 6 pt label saved at 100 dpi is 8 px tall: its letters are ~5 px.
MIN_TEXT_PX = 8 * 100 / 72
OVERLAP_PX = 1.5  # bounding boxes that share less than this (in both directions) merely touch


def _drawn_texts(fig: Figure) -> list[Text]:
    """Every non-empty text a draw of the figure puts on the page (titles, labels, tick labels within the view,
    legend entries, contour labels, table cells, annotations): recorded while the figure draws, so a tick label
    the axis does not show, or a text of a hidden panel, is not counted."""
    drawn: list[Text] = []
    draw = Text.draw

    def recording(self, renderer, *args, **kwargs):
        draw(self, renderer, *args, **kwargs)
        if self.get_visible() and self.get_text().strip() and all(d is not self for d in drawn):
            drawn.append(self)

    Text.draw = recording
    try:
        FigureCanvasAgg(fig).draw()
    finally:
        Text.draw = draw
    return drawn


def _owners(fig: Figure) -> dict[int, object]:
    """id(text) -> the axes it belongs to (its tick labels, axis labels, title, legend, table, contour labels);
    texts of the figure itself (suptitle, figure legend) have none."""
    owners: dict[int, object] = {}
    for ax in fig.axes:
        for t in ax.findobj(Text):
            owners.setdefault(id(t), ax)
        for table in ax.tables:  # a table's cells are not among the axes' children
            for cell in table.get_celld().values():
                owners.setdefault(id(cell.get_text()), ax)
    return owners


def _shares_place(a, b) -> bool:
    """Twins (twinx/twiny) occupy the same box: their texts belong to either."""
    return a is b or (a is not None and b is not None and a.bbox.bounds == b.bbox.bounds)


def _overlap(a: Bbox, b: Bbox) -> bool:
    return (min(a.x1, b.x1) - max(a.x0, b.x0) > OVERLAP_PX) and (min(a.y1, b.y1) - max(a.y0, b.y0) > OVERLAP_PX)


def _corners(t: Text, box: Bbox, renderer) -> np.ndarray:
    """The four corners of a text's own (rotated) rectangle: its window extent is the axis-aligned box around it,
    which for a slanted 3-D axis label covers far more than the letters. The rectangle has the same centre."""
    angle = np.radians(t.get_rotation())
    if abs(np.sin(2 * angle)) < 1e-6:  # 0 or 90 degrees: the box is the rectangle
        return np.array([[box.x0, box.y0], [box.x1, box.y0], [box.x1, box.y1], [box.x0, box.y1]])
    lines = t.get_text().split("\n")
    sizes = [renderer.get_text_width_height_descent(line or " ", t.get_fontproperties(), ismath="TeX" if
                                                    t.get_usetex() else t._preprocess_math(line)[1]) for line in lines]
    w = max(s[0] for s in sizes)
    h = sum(s[1] for s in sizes) * (t.get_linespacing() if len(lines) > 1 else 1.0)
    c, s = np.cos(angle), np.sin(angle)
    half = np.array([[-w, -h], [w, -h], [w, h], [-w, h]]) / 2
    return np.array([(box.x0 + box.x1) / 2, (box.y0 + box.y1) / 2]) + half @ np.array([[c, s], [-s, c]])


def _rectangles_overlap(a: np.ndarray, b: np.ndarray) -> bool:
    """Separating axis test of two convex quadrilaterals, with :data:`OVERLAP_PX` of tolerance."""
    for poly in (a, b):
        for k in range(4):
            edge = poly[(k + 1) % 4] - poly[k]
            normal = np.array([-edge[1], edge[0]]) / (np.hypot(*edge) or 1.0)
            pa, pb = a @ normal, b @ normal
            if min(pa.max(), pb.max()) - max(pa.min(), pb.min()) <= OVERLAP_PX:
                return False
    return True


def _name(t: Text) -> str:
    text = t.get_text().replace("\n", " ")
    return repr(text if len(text) <= 40 else text[:37] + "...")


def text_problems(fig: Figure, dpi: float | None = None) -> list[str]:
    """Text that cannot be read at the saved size (``dpi``: the resolution the figure is saved at; default the
    figure's own): smaller than :data:`MIN_TEXT_PX`; cut off at the figure's edge; lying over another axes (a
    title running into a colour bar, a 3-D panel's z label under its neighbour); or over other text."""
    dpi = dpi or fig.dpi
    fig.set_dpi(dpi)
    texts = _drawn_texts(fig)
    renderer = fig.canvas.get_renderer()
    problems = []
    page = fig.bbox
    boxes = [t.get_window_extent(renderer) for t in texts]
    axes = [ax for ax in fig.axes if ax.get_visible()]
    areas = [ax.get_window_extent(renderer) for ax in axes]
    owners = _owners(fig)
    for t, box in zip(texts, boxes):
        px = t.get_fontsize() * dpi / 72
        if px < MIN_TEXT_PX - 1e-9:
            problems.append(f"text {_name(t)} is {t.get_fontsize():g} pt = {px:.1f} px at {dpi:g} dpi: "
                            f"unreadable (at least {MIN_TEXT_PX:.1f} px, 8 pt at 100 dpi)")
        if box.x0 < page.x0 - 1 or box.y0 < page.y0 - 1 or box.x1 > page.x1 + 1 or box.y1 > page.y1 + 1:
            problems.append(f"text {_name(t)} is cut off at the figure's edge")
        owner = owners.get(id(t))
        for ax, area in zip(axes, areas):
            if _shares_place(owner, ax):
                continue
            if owner is None and t in [lg_t for lg in fig.legends for lg_t in lg.get_texts()]:
                continue  # figure legends: legend_problems checks them against the axes
            if _overlap(box, area):
                what = "a colour bar" if _is_colorbar(ax) else f"axes {ax.get_title() or ax.get_label()!r}"
                problems.append(f"text {_name(t)} of {_place(owner)} runs into {what}")
    corners = [_corners(t, box, renderer) for t, box in zip(texts, boxes)]
    for i in range(len(texts)):
        for j in range(i + 1, len(texts)):
            if _overlap(boxes[i], boxes[j]) and _rectangles_overlap(corners[i], corners[j]):
                problems.append(f"text {_name(texts[i])} overlaps text {_name(texts[j])}")
    return problems


def _place(owner) -> str:
    return "the figure" if owner is None else f"axes {owner.get_title() or owner.get_label()!r}"


def figure_problems(fig: Figure, dpi: float | None = None) -> list[str]:
    return axis_problems(fig) + legend_problems(fig) + text_problems(fig, dpi)


def check_figure(fig: Figure, dpi: float | None = None) -> None:
    """Every check above; ``dpi``: the resolution the figure is saved at (the checks of text size and place
    are in the saved image's pixels)."""
    problems = figure_problems(fig, dpi)
    assert not problems, "\n".join(problems)
