"""A 3-D view of every zone (open and non-manifold edges drawn over it) and a CSV of zones and faces.

The CSV lists every face when the options' faces_csv says so (by default up to MAX_LISTED_FACES faces),
whether or not the result does: its per-face numbers come from the solve (``Solved.files``, present only
then), its names from the request."""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Iterator
from itertools import repeat

import numpy as np
from matplotlib.figure import Figure  # no pyplot: no global figure state
from matplotlib.ticker import MaxNLocator
from mpl_toolkits.mplot3d.art3d import Poly3DCollection

from plantsolve.schemas.polyhedra import PolyhedraRequest, PolyhedraResult
from plantsolve.solvers.base import Artifact, Solved
from plantsolve.solvers.plots import figure_artifact
from plantsolve.schemas.polyhedra import MAX_LISTED_FACES
from plantsolve.solvers.polyhedra import bulk_csv
from plantsolve.solvers.polyhedra.counted import subsurface_copies
from plantsolve.solvers.polyhedra.polygons import FaceIds, Polygons, from_request
from plantsolve.solvers.polyhedra.solve import FACE_TABLE

MAX_PANELS = 12
MAX_FACES_DRAWN = 20_000


def _zone_faces(poly: Polygons, z: int) -> np.ndarray:
    """The enclosure faces of zone ``z``; a spread of MAX_FACES_DRAWN of them when there are more (the whole
    shape shows, thinned, rather than its first part)."""
    faces = np.flatnonzero((poly.face_zone == z).any(axis=1))
    if len(faces) > MAX_FACES_DRAWN:
        faces = faces[np.linspace(0, len(faces) - 1, MAX_FACES_DRAWN).astype(np.int64)]
    return faces


def zones_figure(request: PolyhedraRequest, result: PolyhedraResult, poly: Polygons | None = None) -> Figure:
    """A 3-D panel per zone (axes in the request's units); one legend below the panels, off the drawings."""
    poly = from_request(request) if poly is None else poly
    zones = result.zones[:MAX_PANELS]
    cols = min(len(zones), 4) or 1
    rows = math.ceil(len(zones) / cols) or 1
    # a fixed layout: constrained layout does not see a 3-D axes' labels, and put the z label under the next panel
    fig = Figure(figsize=(4.8 * cols, 4.4 * rows + 0.7))
    fig.subplots_adjust(left=0.0, right=0.93, bottom=0.7 / (4.4 * rows + 0.7), top=1 - 0.35 / (4.4 * rows + 0.7),
                        wspace=0.18, hspace=0.15)
    labels: dict[str, object] = {}
    zone_index = {zid: i for i, zid in enumerate(poly.zone_ids)}
    subsurfaces = np.flatnonzero(poly.face_parent >= 0)
    units = request.units
    for k, zone in enumerate(zones):
        ax = fig.add_subplot(rows, cols, k + 1, projection="3d")
        z = zone_index[zone.id]
        polygons = [_outer_loop(poly, f) for f in _zone_faces(poly, z)]
        hosted = subsurfaces[(poly.face_zone[poly.face_parent[subsurfaces]] == z).any(axis=1)]
        windows = [_outer_loop(poly, f) for f in hosted]
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


def _outer_loop(poly: Polygons, f: int) -> np.ndarray:
    loop = poly.face_loop_start[f]
    return poly.points[poly.loop_vertices[poly.loop_start[loop]:poly.loop_start[loop + 1]]]


def figures(request: PolyhedraRequest, result: PolyhedraResult) -> dict[str, Figure]:
    return {"zones": zones_figure(request, result)}


def _table(result: PolyhedraResult, poly: Polygons, face_table: np.ndarray | None,
           copies: np.ndarray | None = None) -> bytes:
    """Zones, then every face when the solve handed over its face table (faces_csv). A zone row's multiplier is the
    zone's, a face row's the number of copies of it its host holds (``copies``; 1 when None), as in the result."""
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    u = result.units
    writer.writerow(["record", "id", "zones", "parent", f"volume [{u}3]", f"signed_volume [{u}3]", f"area [{u}2]",
                     f"net_area [{u}2]", f"perimeter [{u}]", "closed", "orientation", "open_edges",
                     "non_manifold_edges", "normal_x [-]", "normal_y [-]", "normal_z [-]", f"planarity_error [{u}]",
                     f"floor_area [{u}2]", "multiplier", "part_of_total_floor_area"])
    for z in result.zones:
        writer.writerow(["zone", z.id, "", "", "" if z.volume is None else repr(z.volume), repr(z.signed_volume),
                         repr(z.surface_area), repr(z.net_surface_area), "", z.closed, z.orientation,
                         z.open_edge_count, z.non_manifold_edge_count, "", "", "", "", repr(z.floor_area),
                         z.multiplier, z.part_of_total_floor_area])
    if face_table is None:
        return out.getvalue().encode()
    host = np.where(poly.face_parent >= 0, poly.face_parent, np.arange(poly.n_faces))
    fz = poly.face_zone[host]  # a subsurface is listed with its host's zones
    names = np.array([*poly.zone_ids, ""], dtype=object)
    zones = names[fz[:, 0]]
    two = np.flatnonzero(fz[:, 1] >= 0)
    zones[two] = [f"{a} {b}" for a, b in zip(names[fz[two, 0]], names[fz[two, 1]])]
    parents = np.full(poly.n_faces, "", dtype=object)
    subs = np.flatnonzero(poly.face_parent >= 0)
    parents[subs] = [poly.face_ids[p] for p in poly.face_parent[subs]]
    ids = poly.face_ids
    named = ids.names if isinstance(ids, FaceIds) else ids
    # a window standing for four on its wall: its row says so, or the rows' net areas would not add up to its host's
    copies = np.ones(poly.n_faces, dtype=np.int64) if copies is None else np.asarray(copies, dtype=np.int64)
    if poly.n_faces > MAX_LISTED_FACES and bulk_csv.writable([*poly.zone_ids, *named]) and \
            np.isfinite(face_table).all():
        # one copy of the rows: each chunk written behind the zone rows as it is made (BytesIO hands its buffer
        # over without copying it); joined at the end, the chunks and the table were both held, 2 x 180 MB
        table = io.BytesIO()
        table.write(out.getvalue().encode())
        table.writelines(_bulk_face_rows(poly, zones, parents, copies, face_table))
        return table.getvalue()
    multipliers = copies.astype(str).tolist()
    columns = [list(map(repr, face_table[:, k].tolist())) for k in range(face_table.shape[1]) if k != 1]
    net = columns[0] if np.array_equal(face_table[:, 0], face_table[:, 1]) else list(map(repr, face_table[:, 1].tolist()))
    area, perimeter, nx, ny, nz, planarity = columns
    blank = repeat("")
    writer.writerows(zip(repeat("face"), poly.face_ids, zones.tolist(), parents.tolist(), blank, blank, area, net,
                         perimeter, blank, blank, blank, blank, nx, ny, nz, planarity, blank, multipliers, blank))
    return out.getvalue().encode()


def _id_cells(poly: Polygons, s: int, e: int) -> np.ndarray:
    ids = poly.face_ids
    if isinstance(ids, FaceIds) and s >= len(ids.names):
        return bulk_csv.numbered_cells(ids.prefix, s - len(ids.names) + 1, e - s)
    return bulk_csv.text_cells(ids[s:e])


def _label_cells(labels: np.ndarray) -> np.ndarray:
    """Cells of a column with few distinct strings (zone names, parents): each distinct one made once."""
    values, index = np.unique(labels.astype(str), return_inverse=True)
    return bulk_csv.text_cells(values.tolist())[index.reshape(-1)]


def _bulk_face_rows(poly: Polygons, zones: np.ndarray, parents: np.ndarray, copies: np.ndarray,
                    face_table: np.ndarray, chunk: int = 20_000) -> Iterator[bytes]:
    """The face rows of a large table in chunks (bulk_csv: 17 significant digits, written by array operations); the
    multipliers made text a chunk at a time (a million faces' at once were 140 MB of strings)."""
    for s in range(0, poly.n_faces, chunk):
        e = min(s + chunk, poly.n_faces)
        n = e - s
        num = [bulk_csv.number_cells(face_table[s:e, k]) for k in range(face_table.shape[1])]
        comma = bulk_csv.literal(",", n)
        yield bulk_csv.rows([
            bulk_csv.literal("face,", n), _id_cells(poly, s, e), comma,
            _label_cells(zones[s:e]), comma, _label_cells(parents[s:e]),
            bulk_csv.literal(",,,", n), num[0], comma, num[1], comma, num[2], bulk_csv.literal(",,,,,", n),
            num[3], comma, num[4], comma, num[5], comma, num[6], bulk_csv.literal(",,", n),
            _label_cells(copies[s:e]), bulk_csv.literal(",\n", n)])


def render_artifacts(request: PolyhedraRequest, solved: Solved) -> list[Artifact]:
    poly = from_request(request)
    table = solved.files.get(FACE_TABLE)
    face_table = np.load(io.BytesIO(table), allow_pickle=False) if table is not None else None
    return [figure_artifact("zones.png", zones_figure(request, solved.result, poly), dpi=100),
            Artifact("zones.csv", "text/csv", _table(solved.result, poly, face_table,
                                                     subsurface_copies(request, poly.n_faces)))]
