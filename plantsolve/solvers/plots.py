"""Saving the kinds' matplotlib figures: one place for the format, the resolution and the media type.

Figures are made with ``matplotlib.figure.Figure`` (no pyplot: no global figure state, safe in threads, and no
interactive backend: a figure without a canvas is saved through Agg for PNG, matplotlib's SVG and PDF backends for
the others). This module imports no matplotlib itself: a process imports it with the first kind's artifacts it
draws, not with the kind map."""

from __future__ import annotations

import io
import math
from typing import TYPE_CHECKING

from plantsolve.solvers.base import Artifact

if TYPE_CHECKING:
    from matplotlib.figure import Figure

DPI = 110
SVG_ID_SALT = "plantsolve"
MEDIA_TYPES = {"png": "image/png", "svg": "image/svg+xml", "pdf": "application/pdf"}


def figure_bytes(fig: Figure, fmt: str = "png", dpi: int = DPI, **savefig: object) -> bytes:
    """The figure saved as ``fmt`` (png, svg or pdf) at ``dpi``. An SVG's element ids are hashes of their content
    under a fixed salt (matplotlib's default salt is a random one per save), so the same figure gives the same bytes
    and the same ``X-Content-SHA256``."""
    buffer = io.BytesIO()
    if fmt == "svg":
        import matplotlib

        with matplotlib.rc_context({"svg.hashsalt": SVG_ID_SALT}):
            fig.savefig(buffer, format=fmt, dpi=dpi, **savefig)
    else:
        fig.savefig(buffer, format=fmt, dpi=dpi, **savefig)
    return buffer.getvalue()


def figure_artifact(name: str, fig: Figure, dpi: int = DPI, **savefig: object) -> Artifact:
    """The figure as an artifact; the format follows the name's extension (``map.png``, ``map.svg``)."""
    fmt = name.rsplit(".", 1)[-1].lower()
    if fmt not in MEDIA_TYPES:
        raise ValueError(f"no figure format for {name!r}; known: {', '.join(MEDIA_TYPES)}")
    return Artifact(name=name, media_type=MEDIA_TYPES[fmt], data=figure_bytes(fig, fmt, dpi, **savefig))


def figure_artifacts(stem: str, fig: Figure, formats: tuple[str, ...] = ("png", "svg"), dpi: int = DPI,
                     **savefig: object) -> list[Artifact]:
    """The figure as one artifact per format (``map.png``, ``map.svg``), laid out once: the first save runs the
    figure's layout engine, which then stands down (``"none"`` keeps every position it set), so the later formats
    are drawn at the same positions without measuring every label again. An SVG carries no date: the same result
    gives the same bytes."""
    out = []
    for fmt in formats:
        extra = {"metadata": {"Date": None}, **savefig} if fmt == "svg" else savefig
        out.append(figure_artifact(f"{stem}.{fmt}", fig, dpi, **extra))
        if fig.get_layout_engine() is not None:
            fig.set_layout_engine("none")
    return out


_SUPERSCRIPT = str.maketrans("-0123456789", "\u207b\u2070\u00b9\u00b2\u00b3\u2074\u2075\u2076\u2077\u2078\u2079")


def decade_label(value: float, _position=None) -> str:
    """'10³' for 1000, '10⁻⁶' for 1e-6, '−10²' for -100 and '0' (a symmetric log axis's middle), as plain text:
    matplotlib's log axes write 10^3 in mathtext, whose parser a fresh job process builds first (about a tenth of a
    second), then lays out as a formula. Not a decade: ''."""
    if value == 0:
        return "0"
    if not math.isfinite(value):
        return ""
    exponent = math.log10(abs(value))
    if abs(exponent - round(exponent)) > 1e-9:
        return ""
    return ("\u2212" if value < 0 else "") + "10" + str(round(exponent)).translate(_SUPERSCRIPT)


def plain_decades(axis) -> None:
    """A log axis's decades labelled '10³' in plain text (the look of matplotlib's own labels, without mathtext);
    a function given as formatter is matplotlib's FuncFormatter."""
    axis.set_major_formatter(decade_label)


def thin_labels(labels: list, renderer=None) -> None:
    """Hide contour labels (``ax.clabel(..., inline=False)``'s texts) that would overlap one already kept: where
    contours bunch (near a singular electrode edge, along a steep map border) matplotlib places labels on top of
    each other. Kept labels get a light backing, since the contour is not broken under them (a broken contour
    under a hidden label would leave a gap)."""
    if not labels:
        return
    fig = labels[0].get_figure(root=True)
    if renderer is None:
        if fig.get_layout_engine() is None:
            # axes at fixed places: only an axes' aspect moves it, and a whole draw would cost as much as the save
            for ax in {label.axes for label in labels}:
                ax.apply_aspect()
        else:
            fig.draw_without_rendering()  # labels know their place only once the figure is laid out
        renderer = fig._get_renderer()
    kept = []
    for label in labels:
        box = label.get_window_extent(renderer).expanded(1.15, 1.3)
        if any(box.overlaps(k) for k in kept):
            label.set_visible(False)
        else:
            kept.append(box)
            label.set_bbox({"boxstyle": "round,pad=0.1", "facecolor": "white", "edgecolor": "none", "alpha": 0.6})
