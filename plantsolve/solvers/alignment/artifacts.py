"""Files made from a result: the aligned PCF and a plot of the gaps before and after."""

from __future__ import annotations

import io

import numpy as np

from plantsolve.schemas.alignment import AlignmentRequest, AlignmentResult
from plantsolve.solvers.alignment.pcf_write import write_aligned_pcf
from plantsolve.solvers.base import Artifact


def _gap_plot(request: AlignmentRequest, result: AlignmentResult) -> bytes:
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    index = {c.id: c for c in request.components}
    before = np.array([
        np.linalg.norm(np.subtract(index[c.from_[0]].ports[c.from_[1]].position, index[c.to[0]].ports[c.to[1]].position))
        for c in request.connections
    ]) if request.connections else np.zeros(0)
    after = np.array([c.position_error for c in result.connections])
    cut = np.array([c.cut for c in result.connections], dtype=bool)
    floor = 1e-16
    fig = Figure(figsize=(8, 4.5), dpi=100)
    ax = fig.add_subplot(1, 1, 1)
    x = np.arange(len(before))
    ax.semilogy(x, np.maximum(before, floor), "o", ms=3, label="gap before")
    ax.semilogy(x[~cut], np.maximum(after[~cut], floor), "s", ms=3, label="gap after (0 plotted at 1e-16)")
    if np.any(cut):
        ax.semilogy(x[cut], np.maximum(after[cut], floor), "x", color="red", ms=6, label="cut")
    tol = result.report.details.get("position_tolerance")
    if tol:
        ax.axhline(tol, color="gray", ls="--", lw=1, label="tolerance")
    ax.set_xlabel("connection (request order)")
    ax.set_ylabel(f"gap [{request.units}]")
    ax.set_title(f"Alignment: {'converged' if result.converged else 'not converged'}, {len(result.cut_connections)} cut")
    ax.legend(loc="best", fontsize=8)
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    return buf.getvalue()


def render_artifacts(request: AlignmentRequest, result: AlignmentResult) -> list[Artifact]:
    text = write_aligned_pcf(request, result)
    enc = request.source_encoding or "utf-8"
    try:
        data = text.encode(enc)  # the bytes of every untouched line stay what the tool wrote
    except UnicodeEncodeError:
        enc, data = "utf-8", text.encode("utf-8")
    charset = "utf-8" if enc == "utf-8-sig" else enc
    return [
        Artifact(name="aligned.pcf", media_type=f"text/plain; charset={charset}", data=data),
        Artifact(name="gaps.png", media_type="image/png", data=_gap_plot(request, result)),
    ]
