"""Files made from a result: the aligned PCF and a plot of the gaps and angle errors before and after."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure  # no pyplot: no global figure state
from matplotlib.lines import Line2D
from matplotlib.ticker import LogFormatter, MaxNLocator, NullFormatter

from plantsolve.schemas.alignment import AlignmentRequest, AlignmentResult
from plantsolve.solvers.alignment.pcf_write import write_aligned_pcf
from plantsolve.solvers.base import Artifact, Solved
from plantsolve.solvers.plots import figure_artifact


_FLOOR = 1e-16  # a closed connection (gap exactly 0) is drawn here on the log axis


def _before(request: AlignmentRequest) -> tuple[np.ndarray, np.ndarray]:
    """Gap (units) and angle error (degrees: between one port direction and the reversed other) of every
    connection as submitted."""
    index = {c.id: c for c in request.components}
    gaps, angles = [], []
    for c in request.connections:
        a, b = index[c.from_[0]].ports[c.from_[1]], index[c.to[0]].ports[c.to[1]]
        gaps.append(float(np.linalg.norm(np.subtract(a.position, b.position))))
        u = np.asarray(a.direction, float) / np.linalg.norm(a.direction)
        v = np.asarray(b.direction, float) / np.linalg.norm(b.direction)
        angles.append(float(np.degrees(2.0 * np.arcsin(np.clip(np.linalg.norm(u + v) / 2.0, 0.0, 1.0)))))
    return np.array(gaps), np.array(angles)


def gaps_figure(request: AlignmentRequest, result: AlignmentResult) -> Figure:
    """Gaps (top, length unit) and angle errors (bottom, degrees) of every connection before and after,
    connections numbered in request order; cut connections marked; tolerances dashed."""
    before, angle_before = _before(request)
    after = np.array([c.position_error for c in result.connections])
    angle_after = np.array([c.angle_error for c in result.connections])
    cut = np.array([c.cut for c in result.connections], dtype=bool)
    x = np.arange(len(before))
    # fixed margins: constrained layout measures every log tick label in extra drawing passes, which was most of
    # the plot's cost and of a small job's CPU; the labels here have a known, short width
    fig = Figure(figsize=(8.5, 6.6))
    fig.subplots_adjust(left=0.1, right=0.98, top=0.94, bottom=0.12, hspace=0.08)
    ax, ax_ang = fig.subplots(2, 1, sharex=True)
    details = result.report.details
    rows = ((ax, before, after, f"gap [{request.units}]", details.get("position_tolerance"), "gap"),
            (ax_ang, angle_before, angle_after, "angle error [deg]", details.get("angle_tolerance_deg"), "angle"))
    for axis, b, a, label, tol, what in rows:
        axis.semilogy(x, np.maximum(b, _FLOOR), "o", ms=3, color="C0")
        axis.semilogy(x[~cut], np.maximum(a[~cut], _FLOOR), "s", ms=3, color="C1")
        if np.any(cut):
            axis.semilogy(x[cut], np.maximum(a[cut], _FLOOR), "x", color="red", ms=6)
        if tol:
            axis.axhline(tol, color="gray", ls="--", lw=1)
        axis.set_ylabel(label)
        # plain tick labels (1e-16): matplotlib's default 10^-16 goes through mathtext, whose parser a fresh
        # process builds first, about a tenth of a second of a small job
        axis.yaxis.set_major_formatter(LogFormatter(labelOnlyBase=True))
        axis.yaxis.set_minor_formatter(NullFormatter())
        axis.grid(True, which="major", axis="y", lw=0.3)
    ax_ang.set_xlabel("connection [index in request order]")
    ax_ang.xaxis.set_major_locator(MaxNLocator(integer=True, nbins=12))
    if len(x):
        ax_ang.set_xlim(-0.5, len(x) - 0.5)
    # on the axes' top edge, where matplotlib's automatic placement leaves a title over x ticks below and a log axis
    # with no offset text; asking it measures every y tick label at each save, a fifth of the plot's CPU
    ax.set_title(f"Alignment: {'converged' if result.converged else 'not converged'}, "
                 f"{len(result.cut_connections)} cut; largest gap {result.max_position_error:.3g} {request.units}, "
                 f"largest angle {result.max_angle_error:.3g} deg", fontsize=10, y=1.0)
    handles = [Line2D([], [], marker="o", ls="", ms=3, color="C0", label="before"),
               Line2D([], [], marker="s", ls="", ms=3, color="C1", label=f"after (closed: drawn at {_FLOOR:g})"),
               Line2D([], [], ls="--", color="gray", label="tolerance")]
    if np.any(cut):
        handles.append(Line2D([], [], marker="x", ls="", ms=6, color="red", label="cut"))
    fig.legend(handles=handles, loc="lower center", ncol=len(handles), fontsize=8, frameon=False)
    return fig


def figures(request: AlignmentRequest, result: AlignmentResult) -> dict[str, Figure]:
    return {"gaps": gaps_figure(request, result)}


def render_artifacts(request: AlignmentRequest, solved: Solved) -> list[Artifact]:
    """The aligned PCF (in the encoding of the uploaded one) and the gaps plot."""
    result = solved.result
    text = write_aligned_pcf(request, result)
    enc = request.source_encoding or "utf-8"
    try:
        data = text.encode(enc)  # the bytes of every untouched line stay what the tool wrote
    except UnicodeEncodeError:
        enc, data = "utf-8", text.encode("utf-8")
    charset = "utf-8" if enc == "utf-8-sig" else enc
    return [
        Artifact(name="aligned.pcf", media_type=f"text/plain; charset={charset}", data=data),
        figure_artifact("gaps.png", gaps_figure(request, result), dpi=100),
    ]
