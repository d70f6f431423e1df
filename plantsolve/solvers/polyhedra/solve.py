"""The polyhedra solver: the paper's stages in order.

1. topology as a generalized map — after the repairs it depends on (merge, T-junctions);
2. measures per orbit — Newell area vectors, divergence-theorem volumes in each zone's frame;
3. diagnostics — open/non-manifold edges, orientation, Euler characteristic, genus;
4. multi-zone complexes — adjacency of zones through shared faces.
"""

from __future__ import annotations

import io
from dataclasses import dataclass, replace

import numpy as np

from plantsolve.schemas.common import Diagnostic, Report
from plantsolve.schemas.polyhedra import FLOOR_CONE_DEG, MAX_LISTED_FACES, PolyhedraRequest, PolyhedraResult
from plantsolve.solvers.base import Progress, Solved, no_progress
from plantsolve.solvers.skipped_input import skipped_lines, source_warnings
from plantsolve.solvers.stages import Stages
from plantsolve.solvers.polyhedra.adjacency import adjacency
from plantsolve.solvers.polyhedra.closure_verdict import totals_not_determined, volumes_not_determined
from plantsolve.solvers.polyhedra.counted import floor_areas_left_out, implausible_multipliers, multipliers_applied, \
    subsurface_copies, subsurface_multipliers_applied
from plantsolve.solvers.polyhedra.declared import compare
from plantsolve.solvers.polyhedra.duplicates import repeated_faces
from plantsolve.solvers.polyhedra.diagnostics import Orientation, Topology, genus, orient, topology
from plantsolve.solvers.polyhedra.gmap import GMap, build_gmap
from plantsolve.solvers.polyhedra.measures import FaceMeasures, UseTerms, face_measures, use_terms
from plantsolve.solvers.polyhedra.file_units import METRES
from plantsolve.solvers.polyhedra.plausibility import ZONE_RANGE_CODES, building_too_low, implausible, \
    zones_all_too_tall
from plantsolve.solvers.polyhedra.polygons import Polygons, from_request
from plantsolve.solvers.polyhedra.repair import Repairs, repair
from plantsolve.solvers.polyhedra.subsurfaces import subsurface_warnings

MAX_LISTED_EDGES = 1000
FACE_TABLE = "faces.npy"  # the per-face numbers the zones.csv artifact lists (Solved.files)
FACE_COLUMNS = ("area", "net_area", "perimeter", "normal_x", "normal_y", "normal_z", "planarity_error")


@dataclass(frozen=True)
class Analysis:
    poly: Polygons
    repairs: Repairs
    gmap: GMap
    measures: FaceMeasures
    terms: UseTerms
    orientation: Orientation
    topology: Topology


def analyse(poly: Polygons, merge_tolerance: float = 1e-6, progress: Progress = no_progress) -> Analysis:
    """Repair, sew the generalized map, measure and diagnose (the paper's method on flat arrays)."""
    st = Stages(progress)
    st.stage(0.05, 0.3, f"repair: {poly.n_faces} faces, merging vertices within {merge_tolerance:g}")
    poly, repairs = repair(poly, merge_tolerance)
    st.stage(0.3, 0.45, "generalized map: darts and their involutions")
    gmap = build_gmap(poly)
    st.stage(0.45, 0.55, "measures: Newell areas per face")
    measures = face_measures(poly)
    n_zones = len(poly.zone_ids)
    st.stage(0.55, 0.65, "measures: volume terms per face use")
    terms = use_terms(measures, gmap.use_face, gmap.use_zone, gmap.use_sign, n_zones)
    # the face terms live on in the use terms: not kept twice (a million faces' origins and fluxes, 46 MB)
    measures = replace(measures, origin=None, flux=None, centroid=None)
    st.stage(0.65, 0.75, "diagnostics: orientation of the sheets")
    volume = terms.flux.sum(axis=1) / 3.0
    orientation = orient(gmap, measures.area[gmap.use_face], volume, n_zones)
    st.stage(0.75, 0.85, "diagnostics: topology (Euler characteristic, genus)")
    loops_per_face = np.diff(poly.face_loop_start)
    topo = topology(gmap, loops_per_face, orientation.sheet, n_zones)
    return Analysis(poly, repairs, gmap, measures, terms, orientation, topo)


def _edge_reports(an: Analysis, groups_idx: np.ndarray) -> list[dict]:
    g = an.gmap.groups
    pts = an.poly.points
    out = []
    for gi in groups_idx[:MAX_LISTED_EDGES]:
        members = g.order[g.starts[gi]:g.starts[gi] + g.counts[gi]]
        faces = sorted({an.poly.face_ids[an.gmap.use_face[an.gmap.use[e]]] for e in members})
        out.append({"start": pts[g.lo[gi]].tolist(), "end": pts[g.hi[gi]].tolist(), "faces": faces,
                    "uses": int(g.counts[gi])})
    return out


def lists_faces(request: PolyhedraRequest, n_faces: int) -> bool:
    """Whether the result lists every face: as the option says, else up to MAX_LISTED_FACES faces."""
    asked = request.options.list_faces
    return n_faces <= MAX_LISTED_FACES if asked is None else asked


def tables_faces(request: PolyhedraRequest, n_faces: int) -> bool:
    """Whether zones.csv has a row per face: as the option says, else up to MAX_LISTED_FACES faces."""
    asked = request.options.faces_csv
    return n_faces <= MAX_LISTED_FACES if asked is None else asked


def distinct_edge_length(poly: Polygons) -> float:
    """Total length of the distinct undirected edges of every loop (subsurfaces included)."""
    lv = poly.loop_vertices
    n_points = max(len(poly.points), 1)
    # the key (lo, hi) built and sorted in place: two temporaries of the edge-uses' length, not five
    other = lv[poly.next_position()]
    key = np.minimum(lv, other)
    key *= n_points
    key += np.maximum(lv, other, out=other)
    del other
    key.sort()
    keys = key[np.r_[True, key[1:] != key[:-1]]] if len(key) else key
    del key
    lo, hi = keys // n_points, keys % n_points
    d = poly.points[hi] - poly.points[lo]
    return float(np.sqrt(np.einsum("ij,ij->i", d, d)).sum())


def floor_areas(an: Analysis, n_zones: int) -> np.ndarray:
    """Per zone, the area of its faces whose outward normal (the orientation found, not the faces' own) points down
    within FLOOR_CONE_DEG of vertical."""
    gmap = an.gmap
    outward_z = an.orientation.factor * gmap.use_sign * an.measures.normal[gmap.use_face, 2]
    down = outward_z < -np.cos(np.radians(FLOOR_CONE_DEG))
    return np.bincount(gmap.use_zone[down], weights=an.measures.area[gmap.use_face[down]], minlength=n_zones)


def zone_sizes(poly: Polygons, gmap: GMap, n_zones: int) -> np.ndarray:
    """(Z, 3) extent of each zone's bounding box along x, y, z (inf where a zone has no face)."""
    lo = np.full((n_zones, 3), np.inf)
    hi = np.full((n_zones, 3), -np.inf)
    if n_zones == 1 and len(poly.points):  # one zone (a mesh): no sort by zone
        mark = np.zeros(len(poly.points), dtype=bool)
        mark[poly.loop_vertices[poly.face_zone[poly.position_face, 0] >= 0]] = True
        used = poly.points[mark]
        return (used.max(axis=0) - used.min(axis=0))[None, :] if len(used) else hi - lo
    position_face = poly.position_face
    for column in range(poly.face_zone.shape[1]):
        zone = poly.face_zone[position_face, column]
        keep = zone >= 0
        order = np.argsort(zone[keep], kind="stable")
        zs, pts = zone[keep][order], poly.points[poly.loop_vertices[keep]][order]
        if not len(zs):
            continue
        starts = np.flatnonzero(np.r_[True, zs[1:] != zs[:-1]])
        lo[zs[starts]] = np.minimum(lo[zs[starts]], np.minimum.reduceat(pts, starts, axis=0))
        hi[zs[starts]] = np.maximum(hi[zs[starts]], np.maximum.reduceat(pts, starts, axis=0))
    return hi - lo


def tolerances(request: PolyhedraRequest) -> tuple[float, float]:
    """merge_tolerance and planarity_tolerance in the request's units: as given, or their defaults, which are
    metres (a request in millimetres merges within 1e-6 m, not 1e-6 mm)."""
    opts, per_metre = request.options, 1.0 / METRES[request.units]
    fields = opts.model_fields_set
    return tuple(getattr(opts, name) if name in fields else type(opts).model_fields[name].default * per_metre
                 for name in ("merge_tolerance", "planarity_tolerance"))


def read_as(request: PolyhedraRequest) -> tuple[str, float] | None:
    """The unit the file's numbers were read in (its name, metres), from the reader's ``source.units``."""
    said = (request.source or {}).get("units") if isinstance(request.source, dict) else None
    try:
        return str(said["file_unit"]), float(said["factor"]) * METRES[request.units]
    except (TypeError, KeyError, ValueError):
        return None


def unit_hint(request: PolyhedraRequest) -> str:
    """How to give the unit an implausible zone suggests (``{unit}`` stands for it): what the file said of its unit
    first, when it said something."""
    said = (request.source or {}).get("units") if isinstance(request.source, dict) else None
    if not isinstance(said, dict):
        return "if so, send units '{unit}' (the results then in {unit})"
    if said.get("basis") in ("request", "units"):
        return (f"if so, upload with options.file_units '{{unit}}' (converted to {request.units}) or send units "
                "'{unit}' (the results then in {unit})")
    return (f"the file's unit was taken as {said.get('file_unit')} ({said.get('evidence')}), but if the numbers are "
            f"in {{unit}}, upload with options.file_units '{{unit}}' (converted to {request.units})")


def solve(request: PolyhedraRequest, progress: Progress = no_progress) -> Solved:
    """Zone volumes, areas and closure diagnostics of polygonal zones (the paper's method: a
    generalized map of the faces, measures per orbit, diagnostics from the orbits). The request has
    passed ``check_input`` (the job domain runs it once, at submission)."""
    n_mesh = len(request.mesh.triangles) if request.mesh is not None else 0
    progress(0.0, f"reading {len(request.faces) + n_mesh} faces")
    merge_tolerance, planarity_tolerance = tolerances(request)
    # no reference kept to the polygons as given: repaired, they are freed (a mesh's loops, tens of MB)
    an = analyse(from_request(request), merge_tolerance, progress)
    poly, gmap, topo = an.poly, an.gmap, an.topology
    listed, tabled = lists_faces(request, poly.n_faces), tables_faces(request, poly.n_faces)  # repair keeps faces
    progress(0.85, "results")
    area = an.measures.area
    n_faces = poly.n_faces
    sub_area = np.zeros(n_faces)
    subs = np.flatnonzero(poly.face_parent >= 0)
    copies = subsurface_copies(request, n_faces)
    np.add.at(sub_area, poly.face_parent[subs], area[subs] * copies[subs])
    net_area = area - sub_area
    normal = an.measures.normal

    warnings: list[Diagnostic] = []
    n_zones = len(poly.zone_ids)
    use_volume = an.terms.flux.sum(axis=1) / 3.0
    group_zone = gmap.groups.zone[gmap.groups.order[gmap.groups.starts]]
    open_zone = group_zone[topo.open_groups]
    nm_zone = group_zone[topo.non_manifold_groups]
    zones = []
    all_closed = True
    total = 0.0
    by_zone = np.argsort(gmap.use_zone, kind="stable")
    zone_bounds = np.searchsorted(gmap.use_zone[by_zone], np.arange(n_zones + 1))
    floors = floor_areas(an, n_zones)
    outside = set(request.zones_outside_total_floor_area)
    for z in range(n_zones):
        if z % max(1, n_zones // 20) == 0:
            progress(0.85 + 0.08 * z / max(n_zones, 1), f"results: zone {z + 1} of {n_zones}")
        uses = by_zone[zone_bounds[z]:zone_bounds[z + 1]]
        faces = gmap.use_face[uses]
        factor = an.orientation.factor[uses]
        conflict = bool(an.orientation.conflict[uses].any())
        n_open = int((open_zone == z).sum())
        closed = n_open == 0 and len(uses) > 0  # a zone whose every face collapsed bounds nothing
        oriented_volume = float((factor * use_volume[uses]).sum())
        signed = float(use_volume[uses].sum())
        repeated = repeated_faces(poly, faces, normal) if (nm_zone == z).any() else []
        volume = abs(oriented_volume) if closed and not conflict and not repeated else None
        all_closed &= volume is not None
        multiplier = request.zone_multipliers.get(poly.zone_ids[z], 1)
        total += (volume or 0.0) * multiplier
        if conflict:
            label = "mixed"
        elif (factor > 0).all():
            label = "outward"
        elif (factor < 0).all():
            label = "inward"
        else:
            label = "mixed"
        nm = topo.non_manifold_groups[nm_zone == z]
        nm_vertices = topo.non_manifold_vertices[z]
        euler = int(topo.euler[z])
        zone_id = poly.zone_ids[z]
        misoriented = faces[factor < 0] if label != "outward" else faces[:0]
        zones.append({
            "id": zone_id, "volume": volume, "signed_volume": signed,
            "surface_area": float(area[faces].sum()), "net_surface_area": float(net_area[faces].sum()),
            "floor_area": float(floors[z]), "multiplier": multiplier,
            "part_of_total_floor_area": poly.zone_ids[z] not in outside,
            "closed": closed, "orientation": label,
            "misoriented_faces": [poly.face_ids[f] for f in (misoriented if listed else misoriented[:MAX_LISTED_EDGES])],
            "misoriented_face_count": int(len(misoriented)),
            "flux_volumes": an.terms.flux[uses].sum(axis=0).tolist(),
            "vector_area_sum": an.terms.area_vector[uses].sum(axis=0).tolist(),
            "open_edges": _edge_reports(an, topo.open_groups[open_zone == z]),
            "open_edge_count": n_open,
            "non_manifold_edges": _edge_reports(an, nm),
            "non_manifold_edge_count": int(len(nm)),
            "non_manifold_vertices": poly.points[nm_vertices[:MAX_LISTED_EDGES]].tolist(),
            "t_junctions_repaired": int(an.repairs.t_junctions_per_zone[z]),
            "components": int(topo.sheets[z]),
            "euler_characteristic": euler,
            "genus": genus(euler, int(topo.sheets[z]), int(topo.boundary_loops[z]),
                           manifold=len(nm) == 0 and len(nm_vertices) == 0, orientable=not conflict),
            "faces": [poly.face_ids[f] for f in faces] if listed else [],
            "face_count": int(len(faces)),
        })
        if not len(uses):
            warnings.append(Diagnostic(code="zone_without_faces", message=(
                f"zone {zone_id!r} has no face left after merging vertices closer than merge_tolerance; "
                "its volume is not given."), details={"zone": zone_id}))
        elif not closed:
            warnings.append(Diagnostic(code="zone_not_closed", message=(
                f"zone {zone_id!r} is not closed: {n_open} open edge(s); its volume is not given."),
                details={"zone": zone_id, "open_edges": n_open}))
        if repeated:
            pairs = ", ".join(f"{poly.face_ids[f]!r} = {poly.face_ids[g]!r}" for f, g in repeated[:5])
            warnings.append(Diagnostic(code="duplicate_faces", message=(
                f"zone {zone_id!r}: {len(repeated)} face(s) repeat another face of the zone (the same vertices, "
                f"facing the same way: {pairs}"
                f"{' ...' if len(repeated) > 5 else ''}); its volume would count them twice and is not given. Remove "
                "the copies."), details={"zone": zone_id, "count": len(repeated),
                                          "faces": [[poly.face_ids[f], poly.face_ids[g]] for f, g in repeated[:100]]}))
        if len(nm):
            warnings.append(Diagnostic(code="non_manifold_edges", message=(
                f"zone {zone_id!r}: {len(nm)} edge(s) shared by more than two faces."),
                details={"zone": zone_id, "count": int(len(nm))}))
        if label != "outward":
            bad = zones[-1]["misoriented_faces"]
            warnings.append(Diagnostic(code=f"orientation_{label}", message=(
                f"zone {zone_id!r}: " + ("the faces cannot be oriented consistently." if conflict else
                                          f"{len(misoriented)} face(s) point into the zone.")),
                details={"zone": zone_id, "faces": bad[:MAX_LISTED_EDGES]}))

    planarity = an.measures.planarity_error
    nonplanar = np.flatnonzero(planarity > planarity_tolerance)
    if len(nonplanar):
        warnings.append(Diagnostic(code="non_planar_faces", message=(
            f"{len(nonplanar)} face(s) deviate from their plane by more than {planarity_tolerance:g} "
            f"{request.units}; areas are Newell's projected areas."),
            details={"faces": {poly.face_ids[f]: float(planarity[f]) for f in nonplanar[:MAX_LISTED_EDGES]}}))
    collapsed = an.repairs.collapsed_faces
    if len(collapsed):
        warnings.append(Diagnostic(code="collapsed_faces_skipped", message=(
            f"{len(collapsed)} face(s) have fewer than 3 distinct vertices after merging vertices closer than "
            f"merge_tolerance ({merge_tolerance:g} {request.units}); they have no area and bound no zone."),
            details={"count": len(collapsed), "faces": [poly.face_ids[f] for f in collapsed[:MAX_LISTED_EDGES]]}))
    if an.repairs.collapsed_holes:
        warnings.append(Diagnostic(code="collapsed_holes_skipped", message=(
            f"{len(an.repairs.collapsed_holes)} face(s) had an inner loop with fewer than 3 distinct vertices after "
            "merging; it was removed."), details={"faces": an.repairs.collapsed_holes[:MAX_LISTED_EDGES]}))
    degenerate = np.setdiff1d(np.flatnonzero(area <= 0), collapsed)
    if len(degenerate):
        warnings.append(Diagnostic(code="zero_area_faces", message=f"{len(degenerate)} face(s) have no area.",
                                   details={"faces": [poly.face_ids[f] for f in degenerate[:MAX_LISTED_EDGES]]}))
    oversized = subs[net_area[poly.face_parent[subs]] < -1e-9 * np.maximum(area[poly.face_parent[subs]], 1)]
    if len(oversized):
        warnings.append(Diagnostic(code="subsurfaces_exceed_host", message=(
            "the subsurfaces of some faces have more area than their host."),
            details={"faces": sorted({poly.face_ids[poly.face_parent[f]] for f in oversized})}))
    warnings.extend(subsurface_warnings(poly, planarity_tolerance, merge_tolerance, request.units))
    if an.repairs.holes_reversed:
        warnings.append(Diagnostic(code="holes_reversed", message=(
            f"{len(an.repairs.holes_reversed)} face(s) had inner loops running the same way as the outer loop; "
            "they were reversed."), details={"faces": an.repairs.holes_reversed[:MAX_LISTED_EDGES]}))

    edge_length_total = distinct_edge_length(poly)

    face_results = []
    if listed:
        face_zones = poly.face_zones
        parent = poly.face_parent.tolist()
        area_l, net_l, perim_l = area.tolist(), net_area.tolist(), an.measures.perimeter.tolist()
        normal_l, planarity_l = normal.tolist(), planarity.tolist()
        zone_names = [[poly.zone_ids[z] for z in zs] for zs in face_zones]
        face_results = [{
            "id": poly.face_ids[f], "zones": zone_names[f] if parent[f] < 0 else zone_names[parent[f]],
            "parent": poly.face_ids[parent[f]] if parent[f] >= 0 else None, "area": area_l[f], "net_area": net_l[f],
            "perimeter": perim_l[f], "normal": normal_l[f], "planarity_error": planarity_l[f],
            "multiplier": int(copies[f])} for f in range(n_faces)]

    details = {
        "zones": n_zones, "faces": n_faces, "darts": gmap.n_darts,
        "merged_vertices": an.repairs.merged_vertices, "repeated_vertices_dropped": an.repairs.dropped_repeats,
        "t_junctions_repaired": int(an.repairs.t_junctions_per_zone.sum()),
        "collapsed_faces": len(an.repairs.collapsed_faces),
        "method": "Newell area vectors and divergence-theorem volumes over the generalized map's orbits",
    }
    if request.source:
        details["source"] = request.source
        skipped = [s for s in request.source.get("skipped") or [] if isinstance(s, dict)]
        if skipped:
            count = request.source.get("skipped_count")
            # the code a failed job's report gives the same objects (jobs.reader_notes): one name either way
            warnings.append(skipped_lines(skipped, "object", count if isinstance(count, int) else None))
        warnings.extend(source_warnings(request.source))
        if isinstance(request.source.get("declared"), dict) and request.source["declared"]:
            rows, differ = compare(request.source["declared"], zones,
                                   {poly.zone_ids[z]: float(floors[z]) for z in range(n_zones)})
            details["declared_comparison"] = rows
            if differ:
                warnings.append(differ)
    warnings.extend(multipliers_applied(zones))
    warnings.extend(implausible_multipliers(zones, request.units, request.source))
    warnings.extend(floor_areas_left_out(zones, request.units))
    warnings.extend(subsurface_multipliers_applied(request, poly, area))
    sizes = zone_sizes(poly, gmap, n_zones)
    hint = unit_hint(request)
    measured = {poly.zone_ids[z]: {"height": float(sizes[z, 2]), "extent": float(sizes[z, :2].max())}
                for z in range(n_zones) if np.isfinite(sizes[z]).all()}
    warnings.extend(implausible(zones, measured, request.units, hint, read_as(request)))
    if not any(w.code == "implausible_zone_height" for w in warnings):  # a height out of range says it already
        warnings.extend(building_too_low(measured, request.units, hint, read_as(request)))
    if not any(w.code in ZONE_RANGE_CODES for w in warnings):  # a zone out of its range names the unit already
        warnings.extend(zones_all_too_tall(measured, request.units, hint, read_as(request)))
    progress(0.95, "adjacency: shared and facing walls")
    adjacent = adjacency(poly, area, normal)
    progress(1.0, "done")
    closed_count = sum(1 for z in zones if z["volume"] is not None)
    partial = totals_not_determined(request.source)
    verdict = volumes_not_determined(zones, warnings)
    # the gravest first: Report.verdict is the first verdict among the warnings
    warnings[:0] = [v for v in (verdict, partial) if v is not None]
    return Solved(PolyhedraResult(
        units=request.units, zones=zones, faces=face_results, faces_listed=listed, faces_in_csv=tabled,
        edge_length_total=edge_length_total,
        adjacency=adjacent, total_volume=total if all_closed else None,
        total_floor_area=float((floors * [z["multiplier"] * z["part_of_total_floor_area"] for z in zones]).sum()),
        report=Report(status="warning" if warnings else "ok",
                      message=f"{closed_count} of {n_zones} zone(s) closed" + (_cut_short(partial) if partial else ""),
                      warnings=warnings, details=details),
    ), files={FACE_TABLE: _npy(area, net_area, an.measures.perimeter, normal, planarity)}
        if tabled else {})


def _cut_short(partial: Diagnostic) -> str:
    """The summary's word on a file cut short: what it names against what was read."""
    said = partial.details
    past = f" and {said['objects_past_cut']} object(s) past the cut" if said["objects_past_cut"] else ""
    return (f"; the file was cut short: it names {said['spaces_named']} space(s){past}, the totals are those of the "
            f"{said['spaces_measured']} read")


def _npy(*columns: np.ndarray) -> bytes:
    """The columns side by side as one .npy file (the per-face numbers zones.csv lists)."""
    out = io.BytesIO()
    np.save(out, np.column_stack(columns), allow_pickle=False)
    return out.getvalue()
