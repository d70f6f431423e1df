"""Checks every plot of every kind must pass: labelled axes with a unit in brackets (x, y and, in 3-D, z),
legends that hide no data (no plotted point under a legend; a figure legend outside every axes), text that
nothing hides (no text over another axes, such as a title running into a colour bar; no text over other text,
such as a graph's node labels over each other; no text cut off at the figure's edge), text large enough to read
at the saved size and distinct from what lies under it (contrast ratio), filled data (an image, filled contours)
that reaches the outline it lies in (no blank band inside the data's range), and, where a kind declares
tolerances, a band drawn for each."""

from __future__ import annotations

import re

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import PolyCollection, QuadMesh
from matplotlib.colors import to_rgba
from matplotlib.contour import ContourSet
from matplotlib.figure import Figure
from matplotlib.image import AxesImage
from matplotlib.lines import Line2D
from matplotlib.patches import Patch
from matplotlib.path import Path
from matplotlib.text import Text
from matplotlib.ticker import FixedLocator
from matplotlib.transforms import Bbox
from scipy import ndimage

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


def text_problems(fig: Figure, dpi: float | None = None, texts: list[Text] | None = None) -> list[str]:
    """Text that cannot be read at the saved size (``dpi``: the resolution the figure is saved at; default the
    figure's own): smaller than :data:`MIN_TEXT_PX`; cut off at the figure's edge; lying over another axes (a
    title running into a colour bar, a 3-D panel's z label under its neighbour); or over other text."""
    dpi = dpi or fig.dpi
    fig.set_dpi(dpi)
    texts = _drawn_texts(fig) if texts is None else texts
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


# ---- contrast of text on what lies under it ------------------------------------------------------------------

# WCAG 2's least contrast ratio for large text and for graphics: plot text is small, so this is the floor (orange
# #ff7f0e on white is 2.5:1, white on viridis' yellow 1.1:1)
MIN_CONTRAST = 3.0


def _luminance(rgb: np.ndarray) -> np.ndarray:
    """WCAG 2 relative luminance of sRGB colours in [0, 1] (last axis: R, G, B)."""
    linear = np.where(rgb <= 0.04045, rgb / 12.92, ((rgb + 0.055) / 1.055) ** 2.4)
    return linear @ np.array([0.2126, 0.7152, 0.0722])


def contrast_ratio(a, b) -> np.ndarray:
    """WCAG 2 contrast ratio of two colours (or arrays of colours): 1 (the same) to 21 (black on white)."""
    la, lb = _luminance(np.asarray(a, dtype=float)[..., :3]), _luminance(np.asarray(b, dtype=float)[..., :3])
    return (np.maximum(la, lb) + 0.05) / (np.minimum(la, lb) + 0.05)


def _render(fig: Figure) -> np.ndarray:
    """The figure as drawn now: RGB in [0, 1], rows from the top; transparent parts over white (a page)."""
    canvas = fig.canvas if isinstance(fig.canvas, FigureCanvasAgg) else FigureCanvasAgg(fig)
    canvas.draw()
    rgba = np.asarray(canvas.buffer_rgba(), dtype=float) / 255.0
    return rgba[..., :3] * rgba[..., 3:] + (1.0 - rgba[..., 3:])


def _pixels(box: Bbox, shape: tuple[int, ...]) -> tuple[slice, slice] | None:
    """The rows and columns of the rendered image under a display box (display y runs up, rows down)."""
    height, width = shape[:2]
    x0, x1 = int(np.floor(max(box.x0, 0))), int(np.ceil(min(box.x1, width)))
    r0, r1 = int(np.floor(max(height - box.y1, 0))), int(np.ceil(min(height - box.y0, height)))
    return (slice(r0, r1), slice(x0, x1)) if x1 > x0 and r1 > r0 else None


def contrast_problems(fig: Figure, dpi: float | None = None, texts: list[Text] | None = None) -> list[str]:
    """Text whose colour is too close to what lies under it: the figure is drawn without its texts, and the
    median contrast ratio of each text's colour against the pixels under its box (under its own background box,
    when it has one) must be at least :data:`MIN_CONTRAST` (contour labels in a line colour on a filled map,
    white labels over the light end of a colour map)."""
    fig.set_dpi(dpi or fig.dpi)
    texts = _drawn_texts(fig) if texts is None else texts
    renderer = fig.canvas.get_renderer()
    boxes = [t.get_window_extent(renderer) for t in texts]
    shown = [t.get_visible() for t in texts]
    engine = fig.get_layout_engine()
    fig.set_layout_engine("none")  # the places as drawn: a layout engine would give the hidden texts' room away
    for t in texts:
        t.set_visible(False)
    try:
        under = _render(fig)
    finally:
        for t, visible in zip(texts, shown):
            t.set_visible(visible)
        fig.set_layout_engine(engine)
    problems = []
    for t, box in zip(texts, boxes):
        place = _pixels(box, under.shape)
        if place is None:
            continue
        background = under[place].reshape(-1, 3)
        patch = t.get_bbox_patch()
        if patch is not None and patch.get_visible():
            face = np.asarray(patch.get_facecolor(), dtype=float)
            background = face[3] * face[:3] + (1 - face[3]) * background
        colour = np.asarray(to_rgba(t.get_color(), t.get_alpha()), dtype=float)
        ink = colour[3] * colour[:3] + (1 - colour[3]) * background
        ratio = float(np.median(contrast_ratio(ink, background)))
        if ratio < MIN_CONTRAST:
            shade = np.median(background, axis=0)
            problems.append(f"text {_name(t)} ({_hex(colour)} on about {_hex(shade)}) has a contrast ratio of "
                            f"{ratio:.1f}:1 with what lies under it: hard to read (at least {MIN_CONTRAST:g}:1)")
    return problems


def _hex(rgb) -> str:
    return "#" + "".join(f"{int(round(255 * float(c))):02x}" for c in list(rgb)[:3])


# ---- filled data that stops short of its outline -------------------------------------------------------------

BAND_PX = 4.0  # a gap narrower than this (in the saved image's pixels) is the outline's stroke or anti-aliasing ...
BAND_SHARE = 0.015  # ... or narrower than this share of the axes' smaller side


def _fillers(ax) -> list:
    """What fills an area with colour-mapped data: images, filled contours, colour meshes (not a scatter)."""
    found = [im for im in ax.images if isinstance(im, AxesImage) and im.get_visible()]
    for c in ax.collections:
        if not c.get_visible():
            continue
        if isinstance(c, ContourSet):
            if c.filled:
                found.append(c)
        elif isinstance(c, (QuadMesh, PolyCollection)) and c.get_array() is not None:
            found.append(c)
    return found


def _label(artist) -> str:
    label = artist.get_label()
    return f" {label!r}" if label and not label.startswith("_") else ""


def _outlines(ax) -> list[tuple[str, Path]]:
    """Closed outlines in display coordinates that data may be meant to fill: a closed line (a pipe wall drawn as a
    circle), a patch (a polygon, a circle), an image's extent."""
    found = []
    for line in ax.get_lines():
        xy = np.asarray(line.get_xydata(), dtype=float)
        xy = xy[np.all(np.isfinite(xy), axis=1)]
        if line.get_visible() and len(xy) >= 4 and line.get_linestyle() not in ("None", "", " "):
            span = float(np.ptp(xy, axis=0).max()) or 1.0
            if np.allclose(xy[0], xy[-1], rtol=0, atol=1e-6 * span):
                found.append((f"the closed line{_label(line)}", Path(ax.transData.transform(xy))))
    for patch in ax.patches:
        if patch.get_visible() and isinstance(patch, Patch):
            found.append((f"the {type(patch).__name__.lower()}{_label(patch)}",
                          patch.get_transform().transform_path(patch.get_path())))
    for im in ax.images:
        x0, x1, y0, y1 = im.get_extent()
        corners = ax.transData.transform([(x0, y0), (x1, y0), (x1, y1), (x0, y1), (x0, y0)])
        found.append(("the image's extent", Path(corners, closed=True)))
    return found


def empty_band_problems(fig: Figure, dpi: float | None = None, drawn: bool = False) -> list[str]:
    """Filled data (an image, filled contours, a colour mesh) that stops short of the closed outline it lies in,
    leaving a blank band inside the data's range: a weight function that ends millimetres before the pipe wall
    drawn round it, an image whose edge columns are empty. A band is the part of the outline's inside that the
    data does not cover, reaches the outline, and is wider than :data:`BAND_PX` and :data:`BAND_SHARE` of the
    axes; holes away from the outline (an island of no data) are not bands."""
    fig.set_dpi(dpi or fig.dpi)
    if not drawn:
        FigureCanvasAgg(fig).draw()
    renderer = fig.canvas.get_renderer()
    height = int(round(fig.bbox.height))
    problems = []
    for ax in fig.axes:
        fillers = _fillers(ax) if ax.get_visible() and not _is_colorbar(ax) and ax.name != "3d" else []
        outlines = _outlines(ax) if fillers else []
        if not outlines:
            continue
        renderer.clear()
        for filler in fillers:  # the data's colours alone
            filler.draw(renderer)
        alpha = np.asarray(renderer.buffer_rgba())[..., 3]
        area = ax.get_window_extent(renderer)
        place = _pixels(area, alpha.shape)
        if place is None:
            continue
        covered = alpha[place] > 0
        rows, cols = np.mgrid[place[0], place[1]]
        centres = np.column_stack([cols.ravel() + 0.5, height - rows.ravel() - 0.5])
        limit = max(BAND_PX, BAND_SHARE * min(area.width, area.height))
        for what, outline in outlines:
            inside = outline.contains_points(centres).reshape(covered.shape)
            if inside.sum() < 100 or (covered & inside).sum() < 0.5 * inside.sum():
                continue  # not an outline this data fills (a small marker, a band drawn over part of it)
            gap = inside & ~covered
            # only gaps that reach the outline: the part of the inside along its edge
            edge = inside & ~ndimage.binary_erosion(inside, iterations=2)
            labels, _ = ndimage.label(gap)
            touching = np.setdiff1d(np.unique(labels[edge & gap]), [0])
            band = np.isin(labels, touching)
            if not band.any():
                continue
            width = float(ndimage.distance_transform_edt(~covered)[band].max())
            if width > limit:
                per_unit = area.width / abs(np.subtract(*ax.get_xlim())) if ax.get_xlim()[0] != ax.get_xlim()[1] else 0
                in_data = f" (about {width / per_unit:.3g} in x data units)" if per_unit else ""
                problems.append(f"axes {ax.get_title() or ax.get_label()!r}: the filled data stops short of {what}, "
                                f"leaving a blank band up to {width:.0f} px{in_data} wide inside it")
    FigureCanvasAgg(fig).draw()  # the renderer holds the whole figure again
    return problems


# ---- tolerance bands ------------------------------------------------------------------------------------------

def _bands(ax, axis: str) -> list[tuple[float, float, float]]:
    """Filled regions of an axes (axhspan/axvspan, fill_between, rectangles): (low, high) along ``axis`` in data
    units and the share of the other axis' view they span."""
    found = []
    index = 1 if axis == "y" else 0
    other = ax.get_xlim() if axis == "y" else ax.get_ylim()
    paths = [p.get_transform().transform_path(p.get_path()) for p in ax.patches if p.get_visible()]
    for c in ax.collections:
        if isinstance(c, PolyCollection) and c.get_visible() and c.get_array() is None:
            paths += [c.get_transform().transform_path(p) for p in c.get_paths()]
    inverse = ax.transData.inverted()
    for path in paths:
        if len(path.vertices) < 3:
            continue
        data = inverse.transform(path.vertices)
        along, across = data[:, index], data[:, 1 - index]
        covered = (min(across.max(), max(other)) - max(across.min(), min(other))) / (abs(other[1] - other[0]) or 1)
        found.append((float(along.min()), float(along.max()), float(covered)))
    return found


def tolerance_problems(fig: Figure, declared: list[dict]) -> list[str]:
    """Each tolerance a kind declares for a figure (its ``tolerances(input, result)`` hook: ``{"axes": title,
    "axis": "y" or "x", "band": (low, high)}`` in the axes' data units) is drawn as a band from low to high along
    that axis (to 1 % of its view) spanning at least half of the other axis: a band, not only the points."""
    problems = []
    for tolerance in declared:
        name, axis, (low, high) = tolerance["axes"], tolerance.get("axis", "y"), tolerance["band"]
        axes = [ax for ax in fig.axes if name in (ax.get_title(), ax.get_label())]
        if not axes:
            problems.append(f"no axes {name!r} for the tolerance {low:g} to {high:g}")
            continue
        ax = axes[0]
        view = ax.get_ylim() if axis == "y" else ax.get_xlim()
        slack = 0.01 * abs(view[1] - view[0])
        if not any(abs(lo - low) <= slack and abs(hi - high) <= slack and share >= 0.5
                   for lo, hi, share in _bands(ax, axis)):
            problems.append(f"axes {name!r}: the tolerance {low:g} to {high:g} on {axis} is drawn as no band")
    return problems


def figure_problems(fig: Figure, dpi: float | None = None, tolerances: list[dict] | None = None) -> list[str]:
    """Every check, with the figure drawn three times instead of five: the text and contrast checks read the texts of
    one draw at the saved resolution, and the band check reads the places of the contrast check's last draw (made at
    that resolution with the layout held), not a draw of its own: a draw is most of a check's CPU."""
    problems = axis_problems(fig) + legend_problems(fig)
    fig.set_dpi(dpi or fig.dpi)
    texts = _drawn_texts(fig)
    return (problems + text_problems(fig, dpi, texts) + contrast_problems(fig, dpi, texts)
            + empty_band_problems(fig, dpi, drawn=True) + tolerance_problems(fig, tolerances or []))


def check_figure(fig: Figure, dpi: float | None = None, tolerances: list[dict] | None = None) -> None:
    """Every check above; ``dpi``: the resolution the figure is saved at (the checks of text size and place
    are in the saved image's pixels); ``tolerances``: the bands the figure must draw (see tolerance_problems)."""
    problems = figure_problems(fig, dpi, tolerances)
    assert not problems, "\n".join(problems)
