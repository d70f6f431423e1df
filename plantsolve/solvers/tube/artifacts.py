"""Files from a result: tube mesh (STL, GLB), deviation-coloured cloud (PLY), LRA and
XYZ+CLR tables (CSV), overview plot (PNG) and, with a nominal, the inspection plot, the overlay of
nominal and measured centrelines (PNG) and the corrections for the next part (CSV)."""

from __future__ import annotations

import csv
import io

import numpy as np
import trimesh
from matplotlib import colormaps
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch
from matplotlib.ticker import MaxNLocator

from plantsolve.schemas.tube import TubeRequest, TubeResult
from plantsolve.solvers.base import Artifact, Solved
from plantsolve.solvers.plots import figure_artifact
from plantsolve.solvers.tube.lra import model_from_rows
from plantsolve.solvers.tube.model import (
    TubeModel,
    build_spine,
    control_polygon,
    quaternion_frame,
    reverse_model,
    sample_centreline,
    spine_distance,
    tube_mesh_arrays,
)
from plantsolve.solvers.tube.nominal_files import resolve_nominal
from plantsolve.solvers.tube.scan import TubeScan


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
    rows = [["row", f"length [{u}]", "rotation [deg]", "angle [deg]", f"bend_radius [{u}]"]]
    for i, r in enumerate(result.lra, 1):
        rows.append([i, f"{r.length:.6f}", f"{r.rotation:.6f}", f"{r.angle:.6f}", f"{r.bend_radius:.6f}"])
    return _csv(rows)


def xyz_clr_csv(result: TubeResult, model: TubeModel) -> bytes:
    u = result.units
    pts, clr = control_polygon(model)
    rows = [["point", f"x [{u}]", f"y [{u}]", f"z [{u}]", f"clr [{u}]"]]
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


def _deviations(scan: TubeScan, result: TubeResult, model: TubeModel):
    """Scan points, their signed distance from the fitted surface, the outlier mask and the colour limit
    (3 × the 95th percentile residual)."""
    pts = scan.points
    d, _ = spine_distance(pts, build_spine(model))
    outlier = np.zeros(len(pts), bool)
    outlier[np.asarray(result.outliers.indices, int)] = True
    return pts, d - model.pipe_radius, outlier, max(3 * result.residuals.p95, 1e-12)


def render_artifacts(scan: TubeScan, solved: Solved) -> list[Artifact]:
    result = solved.result
    model = model_from_result(result)
    out: list[Artifact] = []
    verts, faces = tube_mesh_arrays(model)
    mesh = trimesh.Trimesh(verts, faces, process=False)
    out.append(Artifact("tube.stl", "model/stl", mesh.export(file_type="stl")))
    out.append(Artifact("tube.glb", "model/gltf-binary", mesh.export(file_type="glb")))

    pts, dev, outlier, lim = _deviations(scan, result, model)
    cloud = trimesh.PointCloud(pts, colors=_deviation_colours(dev, lim, outlier))
    out.append(Artifact("deviation.ply", "application/x-ply", cloud.export(file_type="ply")))
    out.append(Artifact("lra.csv", "text/csv", lra_csv(result)))
    out.append(Artifact("xyz_clr.csv", "text/csv", xyz_clr_csv(result, model)))
    out.append(Artifact("centreline.dxf", "image/vnd.dxf", centreline_dxf(model, result.units)))
    if result.inspection is not None and result.inspection.corrections:
        out.append(Artifact("corrections.csv", "text/csv", corrections_csv(result)))

    for name, fig in figures(scan, result, pts=pts, dev=dev, outlier=outlier, lim=lim).items():
        out.append(figure_artifact(f"{name}.png", fig))
    return out


def overview_figure(result: TubeResult, model: TubeModel, pts: np.ndarray, dev: np.ndarray, outlier: np.ndarray,
                    lim: float) -> Figure:
    """The scan coloured by deviation with the fitted centreline (3-D, axes in the request's units), the
    histogram of signed distances, and the LRA table in a panel of its own (it used to sit over the bars)."""
    u = result.units
    # no pyplot: jobs render in parallel threads. Fixed places (where constrained layout put them for the example),
    # not a layout engine: measuring the 3-D axes' labels was half the plot's cost; the histogram sits a little
    # further right, clear of the colour bar's label with counts of five digits
    fig = Figure(figsize=(14, 5.6))
    ax = fig.add_axes((0.0117, 0.1367, 0.3271, 0.8177), projection="3d")
    rng = np.random.default_rng(0)
    inl_idx = np.flatnonzero(~outlier)
    show = rng.choice(inl_idx, min(len(inl_idx), 20_000), replace=False)
    sc = ax.scatter(*pts[show].T, c=np.clip(dev[show], -lim, lim), cmap="coolwarm", s=1, vmin=-lim, vmax=lim)
    c, _ = sample_centreline(model, max(model.pipe_radius / 2, 1e-9))
    ax.plot(*c.T, "k-", lw=1.5, label="fitted centreline")
    cp, _ = control_polygon(model)
    ax.plot(*cp.T, "g--", lw=0.8, label="control polygon (XYZ)")
    # labels a little further out than matplotlib puts them: its 3-D tick labels ran into them
    for axis, name in ((ax.xaxis, "x"), (ax.yaxis, "y"), (ax.zaxis, "z")):
        axis.set_major_locator(MaxNLocator(5))
        axis.set_label_text(f"{name} [{u}]")
        axis.labelpad = 12
    span = np.ptp(pts[show], axis=0).max() / 2
    mid = (pts[show].max(0) + pts[show].min(0)) / 2
    ax.set_xlim(mid[0] - span, mid[0] + span); ax.set_ylim(mid[1] - span, mid[1] + span)
    ax.set_zlim(mid[2] - span, mid[2] + span)
    ax.set_title(f"{len(result.lra) - 1} bends, pipe radius {result.pipe_radius:.4g} {u}")
    # padded clear of the z label, which matplotlib puts to the right of the 3-D box
    bar = fig.add_axes((0.4224, 0.3003, 0.0098, 0.4906), label="<colorbar>")  # the label fig.colorbar(ax=) gives
    fig.colorbar(sc, cax=bar, label=f"deviation [{u}]")
    ax2 = fig.add_axes((0.538, 0.1367, 0.241, 0.8177))
    ax2.hist(dev[~outlier], bins=80, color="steelblue", label="inlier samples")
    ax2.set_xlabel(f"signed distance to surface [{u}]")
    ax2.set_ylabel("samples per bin [count]")
    ax2.set_title(f"median |r| {result.residuals.median:.3g} {u}, p95 {result.residuals.p95:.3g} {u}")
    ax3 = fig.add_axes((0.7856, 0.1367, 0.2114, 0.8177))
    ax3.axis("off")
    rows = result.lra[:24]
    table = ax3.table(cellText=[[i + 1, f"{r.length:.2f}", f"{r.rotation:.1f}", f"{r.angle:.2f}", f"{r.bend_radius:.2f}"]
                                for i, r in enumerate(rows)],
                      colLabels=["row", f"L [{u}]", "R [deg]", "A [deg]", f"CLR [{u}]"], cellLoc="right",
                      bbox=[0.0, 1.0 - min(1.0, 0.055 * (len(rows) + 1)), 1.0, min(1.0, 0.055 * (len(rows) + 1))])
    table.auto_set_font_size(False)
    table.set_fontsize(8)
    ax3.set_title("LRA" + (f" (first {len(rows)} of {len(result.lra)} rows)" if len(result.lra) > len(rows) else ""))
    handles = [Line2D([], [], color="k", lw=1.5, label="fitted centreline"),
               Line2D([], [], color="g", ls="--", lw=0.8, label="control polygon (XYZ)"),
               Patch(color="steelblue", label="inlier samples (histogram)")]
    fig.legend(handles=handles, loc="lower center", ncol=3, fontsize=8)
    return fig


def corrections_csv(result: TubeResult) -> bytes:
    """Per LRA row: nominal, measured, deviation (measured − nominal), pass / fail / not determined with the
    failed and the undetermined fields, the part's verdict, the end points out of tolerance and those not
    determined, and the next part's deltas, springback (commanded − measured) and command. Units in the header. The
    part's verdict stands on every row: end points out of tolerance fail a part whose every row is within its
    tolerances (deviations that stack along the tube), and a table of rows alone said 'pass' on each."""
    ins, u = result.inspection, result.units
    ends_out = " ".join(e.end for e in ins.end_points if e.ok is False)
    ends_open = " ".join(e.end for e in ins.end_points if e.ok is None)
    head = ["row"]
    for what in ("nominal", "measured", "deviation"):
        head += [f"{what}_length [{u}]", f"{what}_rotation [deg]", f"{what}_angle [deg]", f"{what}_clr [{u}]"]
    head += ["status", "failed_fields", "undetermined_fields", "part_verdict", "end_points_failed",
             "end_points_not_determined", f"delta_length [{u}]", "delta_rotation [deg]", "delta_angle [deg]",
             "springback [deg]", f"next_length [{u}]", "next_rotation [deg]", "next_angle [deg]", f"next_clr [{u}]"]
    rows = [head]

    def num(v):
        return "" if v is None else f"{v:.6f}"

    for r, c in zip(ins.rows, ins.corrections):
        checks = [r.length, r.rotation, r.angle, r.bend_radius]
        line = [r.row]
        for what in ("nominal", "measured", "deviation"):
            line += [num(getattr(f, what)) if f is not None else "" for f in checks]
        line += [_state(r), " ".join(r.failed), " ".join(r.undetermined), ins.verdict, ends_out, ends_open,
                 num(c.delta_length), num(c.delta_rotation), num(c.delta_angle), num(c.springback),
                 num(c.next.length), num(c.next.rotation), num(c.next.angle), num(c.next.bend_radius)]
        rows.append(line)
    return _csv(rows)


def _row_anchors(model: TubeModel) -> np.ndarray:
    """Where each LRA row is shown: the middle of its bend's arc, and for the last row the middle of the last
    straight."""
    sp = build_spine(model)
    out = []
    for k in np.flatnonzero(sp.kind == 1):
        phi = 0.5 * sp.angle[k]
        out.append(sp.centre[k] - sp.radius[k] * np.cos(phi) * sp.normal[k] + sp.radius[k] * np.sin(phi) * sp.tangent[k])
    out.append(0.5 * (sp.start[-1] + sp.end[-1]))
    return np.array(out)


def _row_label(row) -> str:
    units = {"length": "L", "rotation": "R", "angle": "A", "bend_radius": "CLR"}
    parts = [f"{units[f]} {getattr(row, f).deviation:+.2f}" for f in row.failed]
    return f"row {row.row}: " + ", ".join(parts)


def overlay_figure(request: TubeRequest, result: TubeResult) -> Figure | None:
    """Nominal (aligned onto the scan by the inspection's best-fit motion) and measured centrelines projected
    on the measured tube's principal planes (plan: 1st–2nd axes, elevation: 1st–3rd), rows out of tolerance
    marked and labelled with their failed fields' deviations (L, CLR in request units; R, A in degrees)."""
    ins = result.inspection
    nominal_given = resolve_nominal(request.options, request.units) if ins is not None else None
    if ins is None or nominal_given is None:
        return None
    u = result.units
    measured = model_from_result(result)
    if ins.reversed:
        measured = reverse_model(measured)
    nominal = model_from_rows(nominal_given.rows, measured.pipe_radius)
    R = quaternion_frame(ins.alignment.quaternion)
    t = np.asarray(ins.alignment.translation, float)
    step = max(build_spine(measured).length.sum() / 800, 1e-9)
    qm, _ = sample_centreline(measured, step)
    qn = sample_centreline(nominal, step)[0] @ R.T + t
    centre = qm.mean(0)
    axes = np.linalg.svd(qm - centre, full_matrices=False)[2]
    anchors = (_row_anchors(measured) - centre) @ axes.T if ins.matched else np.zeros((0, 3))
    bad = [r for r in ins.rows if r.ok is False]
    fig = Figure(figsize=(12, 5.6), layout="constrained")
    for ax, (i, j), view in zip(fig.subplots(1, 2), ((0, 1), (0, 2)), ("plan", "elevation")):
        pm, pn = (qm - centre) @ axes.T, (qn - centre) @ axes.T
        ax.plot(pn[:, i], pn[:, j], "k--", lw=1.2)
        ax.plot(pm[:, i], pm[:, j], "C0-", lw=1.6)
        for r in bad:
            a = anchors[r.row - 1]
            ax.plot(a[i], a[j], "o", color="C3", ms=7, mfc="none", mew=1.8)
            ax.annotate(_row_label(r), (a[i], a[j]), xytext=(6, 6), textcoords="offset points", fontsize=8,
                        color="C3")
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_xlabel(f"1st principal axis of the measured centreline [{u}]")
        ax.set_ylabel(f"{'2nd' if j == 1 else '3rd'} principal axis [{u}]")
        ax.set_title(view)
    ends = ", ".join(f"{e.end} {e.deviation:.3g} {u}" + ("" if e.determined else " (not determined)")
                     for e in ins.end_points)
    open_rows = f"; rows not determined {', '.join(map(str, ins.undetermined_rows))}" if ins.undetermined_rows else ""
    fig.suptitle(f"Inspection {ins.verdict.replace('_', ' ').upper()}: rows out of tolerance "
                 f"{', '.join(map(str, ins.failed_rows)) or 'none'}{open_rows}; end points {ends}"
                 + ("" if ins.matched else f"; nominal {ins.nominal_bends} bends, scan {ins.measured_bends}"))
    handles = [Line2D([], [], color="k", ls="--", lw=1.2, label="nominal (best-fit aligned)"),
               Line2D([], [], color="C0", lw=1.6, label="measured"),
               Line2D([], [], color="C3", marker="o", ls="", mfc="none", mew=1.8,
                      label="row out of tolerance (deviation: L, CLR [" + u + "], R, A [deg])")]
    fig.legend(handles=handles, loc="outside lower center", ncol=3, fontsize=8)
    return fig


# the per-row panels of the inspection plot: field, axis label and unit ("{u}": the result's length unit)
ROW_FIELDS = (("length", "length", "{u}"), ("rotation", "rotation", "deg"), ("angle", "bend angle", "deg"),
              ("bend_radius", "CLR", "{u}"))
VERDICT_COLOURS = {"pass": "C0", "fail": "C3", "not determined": "0.7"}
STATES = {True: "pass", False: "fail", None: "not determined"}


def _state(check) -> str:
    """A row's, a field's or an end point's verdict in words, from its ``ok`` (null where the samples do not
    determine it)."""
    return STATES[check.ok]


def _row_panel(ax, ins, name: str, label: str, unit: str) -> None:
    """Deviation (measured − nominal) of one field per LRA row: bars coloured by verdict, ±2 sigma whiskers,
    and the tolerance band (±tolerance about zero) the verdict is taken against."""
    checks = [(r.row, getattr(r, name)) for r in ins.rows if getattr(r, name) is not None]
    tol = getattr(ins.tolerances, name) if ins.tolerances is not None else None
    if tol:
        ax.axhspan(-tol, tol, color="C2", alpha=0.18, lw=0, label="tolerance band")
        for y in (-tol, tol):
            ax.axhline(y, color="C2", lw=0.8)
    ax.axhline(0.0, color="0.4", lw=0.6)
    lim = max([abs(c.deviation) + 2 * (c.sigma or 0.0) for _, c in checks] + [1.3 * tol if tol else 0.0, 1e-12])
    for row, c in checks:
        state = _state(c)
        ax.bar(row, c.deviation, 0.6, color=VERDICT_COLOURS[state], hatch="//" if state == "not determined" else None,
               edgecolor="0.35" if state == "not determined" else None, lw=0.5)
        if c.sigma:
            ax.errorbar(row, c.deviation, yerr=2 * c.sigma, color="k", lw=0.8, capsize=2)
    ax.set_ylim(-1.15 * lim, 1.15 * lim)
    ax.set_xticks([row for row, _ in checks])
    ax.set_xlim(0.4, max([row for row, _ in checks] + [1]) + 0.6)
    ax.set_xlabel("LRA row [number]")
    ax.set_ylabel(f"{label} deviation [{unit}]")
    ax.set_title(f"{label}" + (f" (±{tol:.3g} {unit})" if tol else ""), fontsize=9)


def inspection_figure(request: TubeRequest, result: TubeResult) -> Figure | None:
    """Deviation along the tube (top): distance of the measured centreline from the nominal one after the
    inspection's best-fit motion, against arc length, bends shaded, with the end points' tolerance at both
    ends; per LRA row (bottom, one panel per field in its unit): the deviation, coloured pass / fail / not
    determined, ±2 sigma, against the tolerance band."""
    ins = result.inspection
    nominal_given = resolve_nominal(request.options, request.units) if ins is not None else None
    if ins is None or nominal_given is None:
        return None
    nominal_rows = nominal_given.rows
    u = result.units
    measured = model_from_result(result)
    if ins.reversed:
        measured = reverse_model(measured)
    nominal = model_from_rows(nominal_rows, measured.pipe_radius)
    R = quaternion_frame(ins.alignment.quaternion)
    t = np.asarray(ins.alignment.translation, float)
    q, _ = sample_centreline(measured, max(build_spine(measured).length.sum() / 800, 1e-9))
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(q, axis=0), axis=1))])
    d, _ = spine_distance((q - t) @ R, build_spine(nominal))
    fig = Figure(figsize=(12, 7.6), layout="constrained")
    grid = fig.add_gridspec(2, 4, height_ratios=[3, 2])
    ax = fig.add_subplot(grid[0, :])
    sp = build_spine(measured)
    ends = np.cumsum(sp.length)
    for k in np.flatnonzero(sp.kind == 1):
        ax.axvspan(ends[k] - sp.length[k], ends[k], color="0.88", lw=0)
    ax.plot(arc, d, "C3-", lw=1.4)
    ax.axhline(ins.sheath_deviation, color="C3", ls=":", lw=1)
    handles = [Line2D([], [], color="C3", lw=1.4, label="deviation along the tube"),
               Line2D([], [], color="C3", ls=":", lw=1, label="sheath deviation (max)"),
               Patch(color="0.88", label="bends")]
    if ins.tolerances is not None and ins.tolerances.end_point:
        # the end points are checked against their tolerance: a band over the first and last tenth of the tube
        tol, span = ins.tolerances.end_point, 0.1 * arc[-1]
        for a, b in ((0.0, span), (arc[-1] - span, arc[-1])):
            ax.fill_between([a, b], 0.0, tol, color="C2", alpha=0.18, lw=0)
        for e, x in zip(ins.end_points, (0.0, arc[-1])):  # an end the samples stop short of is no pass: grey
            ax.plot(x, e.deviation, "D", color=VERDICT_COLOURS[_state(e)], ms=6)
        handles += [Patch(color="C2", alpha=0.18, label=f"end-point tolerance (±{tol:.3g} {u})"),
                    Line2D([], [], color="0.3", marker="D", ls="",
                           label="end point after best fit (blue: within, red: out, grey: not determined)")]
        ax.set_ylim(0.0, 1.1 * max(float(d.max()), tol, *(e.deviation for e in ins.end_points)))
    ax.set_xlabel(f"arc length along the measured centreline [{u}]")
    ax.set_ylabel(f"distance from nominal centreline [{u}]")
    verdict = ins.verdict.replace("_", " ").upper()
    ax.set_title(f"Inspection {verdict}: sheath deviation {ins.sheath_deviation:.3g} {u} (rms {ins.sheath_rms:.3g} {u})"
                 + ("" if ins.matched else f"; nominal {ins.nominal_bends} bends, scan {ins.measured_bends}"))
    panels = [fig.add_subplot(grid[1, k]) for k in range(4)]
    if ins.rows:
        for a, (name, label, unit) in zip(panels, ROW_FIELDS):
            _row_panel(a, ins, name, label, unit.format(u=u))
        handles += [Patch(color="C2", alpha=0.18, label="tolerance band"),
                    Patch(color=VERDICT_COLOURS["pass"], label="within tolerance"),
                    Patch(color=VERDICT_COLOURS["fail"], label="out of tolerance"),
                    Patch(facecolor=VERDICT_COLOURS["not determined"], hatch="//", edgecolor="0.35",
                          label="not determined (a bound, or σ > tolerance)"),
                    Line2D([], [], color="k", lw=0.8, label="±2 sigma")]
    else:
        fig.delaxes(panels[1]), fig.delaxes(panels[2]), fig.delaxes(panels[3])
        a = panels[0]
        a.set_subplotspec(grid[1, :])
        a.text(0.5, 0.5, f"not comparable: the nominal has {ins.nominal_bends} bend(s), the scan "
               f"{ins.measured_bends}; no per-row deviations", ha="center", va="center", transform=a.transAxes)
        a.set_xticks([])
        a.set_yticks([])
        a.set_xlabel("LRA row [number]")
        a.set_ylabel("deviation [-]")
    fig.legend(handles=handles, loc="outside lower center", ncol=4, fontsize=8)
    return fig


def figures(scan: TubeScan, result: TubeResult, pts: np.ndarray | None = None, dev: np.ndarray | None = None,
            outlier: np.ndarray | None = None, lim: float | None = None) -> dict[str, Figure]:
    """Every plot by artifact stem: ``overview`` and, with a nominal, ``inspection`` and ``inspection_overlay``."""
    model = model_from_result(result)
    if pts is None:
        pts, dev, outlier, lim = _deviations(scan, result, model)
    out = {"overview": overview_figure(result, model, pts, dev, outlier, lim)}
    fig = inspection_figure(scan.request, result)
    if fig is not None:
        out["inspection"] = fig
        out["inspection_overlay"] = overlay_figure(scan.request, result)
    return out
