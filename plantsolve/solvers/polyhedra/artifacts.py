"""A 3-D view of every zone (open and non-manifold edges drawn over it) and a CSV of zones and faces."""

from __future__ import annotations

import csv
import io
import math

import numpy as np
from matplotlib.figure import Figure  # no pyplot: no global figure state
from matplotlib.ticker import MaxNLocator
from mpl_toolkits.mplot3d.art3d import Poly3DCollection

from plantsolve.schemas.polyhedra import PolyhedraRequest, PolyhedraResult
from plantsolve.solvers.base import Artifact, Solved
from plantsolve.solvers.plots import figure_artifact
from plantsolve.solvers.polyhedra.polygons import from_request

MAX_PANELS = 12
MAX_FACES_DRAWN = 20_000


def zones_figure(request: PolyhedraRequest, result: PolyhedraResult) -> Figure:
    """A 3-D panel per zone (axes in the request's units); one legend below the panels, off the drawings."""
    poly = from_request(request)
    zones = result.zones[:MAX_PANELS]
    cols = min(len(zones), 4) or 1
    rows = math.ceil(len(zones) / cols) or 1
    # a fixed layout: constrained layout does not see a 3-D axes' labels, and put the z label under the next panel
    fig = Figure(figsize=(4.8 * cols, 4.4 * rows + 0.7))
    fig.subplots_adjust(left=0.0, right=0.93, bottom=0.7 / (4.4 * rows + 0.7), top=1 - 0.35 / (4.4 * rows + 0.7),
                        wspace=0.18, hspace=0.15)
    labels: dict[str, object] = {}
    face_index = {fid: i for i, fid in enumerate(poly.face_ids)}
    units = request.units
    for k, zone in enumerate(zones):
        ax = fig.add_subplot(rows, cols, k + 1, projection="3d")
        polygons = []
        for fid in zone.faces[:MAX_FACES_DRAWN]:
            f = face_index[fid]
            loop = poly.face_loop_start[f]
            polygons.append(poly.points[poly.loop_vertices[poly.loop_start[loop]:poly.loop_start[loop + 1]]])
        own = set(zone.faces)
        windows = [poly.points[poly.loop_vertices[poly.loop_start[poly.face_loop_start[f]]:
                                                  poly.loop_start[poly.face_loop_start[f] + 1]]]
                   for f in range(poly.n_faces) if poly.face_parent[f] >= 0 and poly.face_ids[poly.face_parent[f]] in own]
        ax.add_collection3d(Poly3DCollection(polygons, facecolor="#9ecae1", edgecolor="#3b6e8f", linewidth=0.4,
                                             alpha=0.35, label="faces"))
        if windows:
            ax.add_collection3d(Poly3DCollection(windows, facecolor="#fdd49e", edgecolor="#b35806", linewidth=0.6,
                                                 alpha=0.8, label="subsurfaces"))
        for edges, color, label in ((zone.open_edges, "red", "open edges"),
                                    (zone.non_manifold_edges, "magenta", "non-manifold edges")):
            for i, e in enumerate(edges):
                ax.plot(*zip(e.start, e.end), color=color, linewidth=2.2, label=label if i == 0 else None)
        if polygons:
            allp = np.concatenate(polygons)
            lo, hi = allp.min(axis=0), allp.max(axis=0)
            span = float((hi - lo).max()) or 1.0
            mid = (lo + hi) / 2
            ax.set_xlim(mid[0] - span / 2, mid[0] + span / 2)
            ax.set_ylim(mid[1] - span / 2, mid[1] + span / 2)
            ax.set_zlim(mid[2] - span / 2, mid[2] + span / 2)
        for axis, name in ((ax.xaxis, "x"), (ax.yaxis, "y"), (ax.zaxis, "z")):
            # fewer tick labels, further from the axis labels; x's last one would meet y's first at the corner
            axis.set_major_locator(MaxNLocator(4, prune="upper" if name == "x" else None))
            axis.set_label_text(f"{name} [{units}]")
            axis.labelpad = 12
        # the box a little smaller than its panel: at full size the z label fell under the next panel (or off
        # the figure), since the layout does not see a 3-D axes' labels
        ax.set_box_aspect(None, zoom=0.8)
        volume = f"V = {zone.volume:.6g} {units}³" if zone.volume is not None else "not closed: no volume"
        ax.set_title(f"{zone.id}: {volume}", fontsize=9)
        handles, names = ax.get_legend_handles_labels()
        for h, n in zip(handles, names):
            labels.setdefault(n, h)
    if len(result.zones) > MAX_PANELS:
        fig.suptitle(f"first {MAX_PANELS} of {len(result.zones)} zones", fontsize=10)
    if labels:
        fig.legend(list(labels.values()), list(labels), loc="lower center", ncol=len(labels), fontsize=8)
    return fig


def figures(request: PolyhedraRequest, result: PolyhedraResult) -> dict[str, Figure]:
    return {"zones": zones_figure(request, result)}


def _table(result: PolyhedraResult) -> bytes:
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    u = result.units
    writer.writerow(["record", "id", "zones", "parent", f"volume [{u}3]", f"signed_volume [{u}3]", f"area [{u}2]",
                     f"net_area [{u}2]", f"perimeter [{u}]", "closed", "orientation", "open_edges",
                     "non_manifold_edges", "normal_x", "normal_y", "normal_z", f"planarity_error [{u}]"])
    for z in result.zones:
        writer.writerow(["zone", z.id, "", "", "" if z.volume is None else repr(z.volume), repr(z.signed_volume),
                         repr(z.surface_area), repr(z.net_surface_area), "", z.closed, z.orientation,
                         z.open_edge_count, z.non_manifold_edge_count, "", "", "", ""])
    for f in result.faces:
        writer.writerow(["face", f.id, " ".join(f.zones), f.parent or "", "", "", repr(f.area), repr(f.net_area),
                         repr(f.perimeter), "", "", "", "", *[repr(c) for c in f.normal], repr(f.planarity_error)])
    return out.getvalue().encode()


def render_artifacts(request: PolyhedraRequest, solved: Solved) -> list[Artifact]:
    return [figure_artifact("zones.png", zones_figure(request, solved.result), dpi=100),
            Artifact("zones.csv", "text/csv", _table(solved.result))]
