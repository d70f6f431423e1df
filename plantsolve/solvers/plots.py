"""Saving the kinds' matplotlib figures: one place for the format, the resolution and the media type.

Figures are made with ``matplotlib.figure.Figure`` (no pyplot: no global figure state, safe in threads)."""

from __future__ import annotations

import io

from matplotlib.figure import Figure

from plantsolve.solvers.base import Artifact

DPI = 110
MEDIA_TYPES = {"png": "image/png", "svg": "image/svg+xml", "pdf": "application/pdf"}


def figure_bytes(fig: Figure, fmt: str = "png", dpi: int = DPI, **savefig: object) -> bytes:
    """The figure saved as ``fmt`` (png, svg or pdf) at ``dpi``."""
    buffer = io.BytesIO()
    fig.savefig(buffer, format=fmt, dpi=dpi, **savefig)
    return buffer.getvalue()


def figure_artifact(name: str, fig: Figure, dpi: int = DPI, **savefig: object) -> Artifact:
    """The figure as an artifact; the format follows the name's extension (``map.png``, ``map.svg``)."""
    fmt = name.rsplit(".", 1)[-1].lower()
    if fmt not in MEDIA_TYPES:
        raise ValueError(f"no figure format for {name!r}; known: {', '.join(MEDIA_TYPES)}")
    return Artifact(name=name, media_type=MEDIA_TYPES[fmt], data=figure_bytes(fig, fmt, dpi, **savefig))
