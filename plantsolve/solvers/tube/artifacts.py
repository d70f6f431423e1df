"""Files from a result: tube mesh (STL, GLB), deviation-coloured cloud (PLY), LRA and
XYZ+CLR tables (CSV), overview plot (PNG)."""

from __future__ import annotations

import csv
import io

import numpy as np
import trimesh
from matplotlib import colormaps
from matplotlib.figure import Figure

from plantsolve.schemas.tube import TubeRequest, TubeResult
from plantsolve.solvers.base import Artifact

from plantsolve.solvers.tube.geometry import (TubeModel, build_spine, control_polygon, quaternion_frame, sample_centreline,
                       spine_distance, tube_mesh_arrays)
from plantsolve.solvers.tube.upload import request_points


def model_from_result(result: TubeResult) -> TubeModel:
    rows = result.lra
    n = len(rows) - 1
    return TubeModel(np.array(result.start, float), quaternion_frame(result.orientation),
                     np.array([r.length for r in rows], float), np.radians([r.rotation for r in rows]),
                     np.radians([r.angle for r in rows[:n]]), np.array([r.bend_radius for r in rows[:n]], float),
                     float(result.pipe_radius))


def _csv(rows: list[list]) -> bytes:
    buf = io.StringIO()
    csv.writer(buf, lineterminator="\n").writerows(rows)
    return buf.getvalue().encode()


def lra_csv(result: TubeResult) -> bytes:
    u = result.units
    rows = [["row", f"length_{u}", "rotation_deg", "angle_deg", f"bend_radius_{u}"]]
    for i, r in enumerate(result.lra, 1):
        rows.append([i, f"{r.length:.6f}", f"{r.rotation:.6f}", f"{r.angle:.6f}", f"{r.bend_radius:.6f}"])
    return _csv(rows)


def xyz_clr_csv(result: TubeResult, model: TubeModel) -> bytes:
    u = result.units
    pts, clr = control_polygon(model)
    rows = [["point", f"x_{u}", f"y_{u}", f"z_{u}", f"clr_{u}"]]
    for i, p in enumerate(pts):
        c = f"{clr[i - 1]:.6f}" if 0 < i < len(pts) - 1 else ""
        rows.append([i, f"{p[0]:.6f}", f"{p[1]:.6f}", f"{p[2]:.6f}", c])
    return _csv(rows)


DXF_UNITS = {"mm": 4, "cm": 5, "m": 6, "in": 1, "ft": 2}  # $INSUNITS codes


def centreline_dxf(model: TubeModel, units: str) -> bytes:
    """The centreline for benders and CAD: each straight a LINE and each bend an ARC in its own plane
    (extrusion = the bend's axis, so the arc runs counter-clockwise from its start to its end), plus the
    whole centreline as a 3-D POLYLINE (arcs densified) for tools that read polylines only."""
    import ezdxf
    from ezdxf.math import OCS

    doc = ezdxf.new("R2013")
    doc.units = DXF_UNITS.get(units, 0)
    doc.layers.add("CENTRELINE")
    doc.layers.add("CENTRELINE_POLYLINE")
    msp = doc.modelspace()
    sp = build_spine(model)
    axes = sp.axis
    for k in range(len(sp.kind)):
        if not sp.kind[k]:
            if np.linalg.norm(sp.end[k] - sp.start[k]) > 0:
                msp.add_line(sp.start[k], sp.end[k], dxfattribs={"layer": "CENTRELINE"})
            continue
        ocs = OCS(axes[k])
        c, a, b = (ocs.from_wcs(v) for v in (sp.centre[k], sp.start[k], sp.end[k]))
        start = float(np.degrees(np.arctan2(a.y - c.y, a.x - c.x)))
        end = float(np.degrees(np.arctan2(b.y - c.y, b.x - c.x)))
        msp.add_arc(center=c, radius=float(sp.radius[k]), start_angle=start, end_angle=end,
                    dxfattribs={"layer": "CENTRELINE", "extrusion": tuple(axes[k])})
    pts, _ = sample_centreline(model, max(model.pipe_radius / 4, 1e-9))
    msp.add_polyline3d([tuple(p) for p in pts], dxfattribs={"layer": "CENTRELINE_POLYLINE"})
    stream = io.StringIO()
    doc.write(stream)
    return stream.getvalue().encode()


def _deviation_colours(dev: np.ndarray, lim: float, outlier: np.ndarray) -> np.ndarray:
    cmap = colormaps["coolwarm"]
    col = (cmap(np.clip(0.5 + 0.5 * dev / max(lim, 1e-300), 0, 1)) * 255).astype(np.uint8)
    col[outlier] = [128, 128, 128, 255]
    return col


def render_artifacts(request: TubeRequest, result: TubeResult) -> list[Artifact]:
    model = model_from_result(result)
    out: list[Artifact] = []
    verts, faces = tube_mesh_arrays(model)
    mesh = trimesh.Trimesh(verts, faces, process=False)
    out.append(Artifact("tube.stl", "model/stl", mesh.export(file_type="stl")))
    out.append(Artifact("tube.glb", "model/gltf-binary", mesh.export(file_type="glb")))

    pts = request_points(request)
    d, _ = spine_distance(pts, build_spine(model))
    dev = d - model.pipe_radius
    outlier = np.zeros(len(pts), bool)
    outlier[np.asarray(result.outliers.indices, int)] = True
    lim = max(3 * result.residuals.p95, 1e-12)
    cloud = trimesh.PointCloud(pts, colors=_deviation_colours(dev, lim, outlier))
    out.append(Artifact("deviation.ply", "application/x-ply", cloud.export(file_type="ply")))
    out.append(Artifact("lra.csv", "text/csv", lra_csv(result)))
    out.append(Artifact("xyz_clr.csv", "text/csv", xyz_clr_csv(result, model)))
    out.append(Artifact("centreline.dxf", "image/vnd.dxf", centreline_dxf(model, result.units)))

    fig = Figure(figsize=(11, 5))  # no pyplot: jobs render in parallel threads
    ax = fig.add_subplot(1, 2, 1, projection="3d")
    rng = np.random.default_rng(0)
    inl_idx = np.flatnonzero(~outlier)
    show = rng.choice(inl_idx, min(len(inl_idx), 20_000), replace=False)
    sc = ax.scatter(*pts[show].T, c=np.clip(dev[show], -lim, lim), cmap="coolwarm", s=1, vmin=-lim, vmax=lim)
    c, _ = sample_centreline(model, max(model.pipe_radius / 2, 1e-9))
    ax.plot(*c.T, "k-", lw=1.5, label="fitted centreline")
    cp, _ = control_polygon(model)
    ax.plot(*cp.T, "g--", lw=0.8, label="control polygon (XYZ)")
    ax.set_xlabel(f"x [{result.units}]"); ax.set_ylabel(f"y [{result.units}]"); ax.set_zlabel(f"z [{result.units}]")
    ax.legend(loc="upper left", fontsize=7)
    span = np.ptp(pts[show], axis=0).max() / 2
    mid = (pts[show].max(0) + pts[show].min(0)) / 2
    ax.set_xlim(mid[0] - span, mid[0] + span); ax.set_ylim(mid[1] - span, mid[1] + span)
    ax.set_zlim(mid[2] - span, mid[2] + span)
    ax.set_title(f"{len(result.lra) - 1} bends, pipe radius {result.pipe_radius:.4g} {result.units}")
    fig.colorbar(sc, ax=ax, shrink=0.6, pad=0.15, label=f"deviation [{result.units}]")
    ax2 = fig.add_subplot(1, 2, 2)
    inl = ~outlier
    ax2.hist(dev[inl], bins=80, color="steelblue", label="inlier samples")
    ax2.set_xlabel(f"signed distance to surface [{result.units}]")
    ax2.set_ylabel("samples per bin")
    ax2.set_ylim(top=ax2.get_ylim()[1] * 1.45)  # headroom: the LRA table must not hide bars
    ax2.legend(loc="upper right", fontsize=7)
    ax2.set_title(f"median |r| {result.residuals.median:.3g} {result.units}, p95 {result.residuals.p95:.3g} {result.units}")
    txt = "\n".join(f"{i + 1}: L {r.length:.2f}  R {r.rotation:.1f}°  A {r.angle:.2f}°  CLR {r.bend_radius:.2f}"
                    for i, r in enumerate(result.lra[:12]))
    ax2.text(0.02, 0.98, txt, transform=ax2.transAxes, va="top", family="monospace", fontsize=7)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    out.append(Artifact("overview.png", "image/png", buf.getvalue()))
    return out
