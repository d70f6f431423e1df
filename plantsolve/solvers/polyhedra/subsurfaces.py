"""Windows and doors that cannot be where their host is: a subsurface off its host's plane or outside its outline (the
coordinates of another wall, a window written in world coordinates over a zone-relative wall), and subsurfaces of
one host that overlap (a window pasted twice). Each one's area is taken off its host's net area all the same, so a
wrong one gives a confident wrong net area: these are named, with the distance or the area counted twice."""

from __future__ import annotations

import numpy as np
import shapely

from plantsolve.schemas.common import Diagnostic
from plantsolve.solvers.polyhedra.holes import plane_frame
from plantsolve.solvers.polyhedra.polygons import Polygons

MAX_LISTED = 100
MAX_PAIRS = 10_000  # pairs of touching subsurfaces measured per host


def _outer(poly: Polygons, face: int) -> np.ndarray:
    loop = poly.face_loop_start[face]
    return poly.points[poly.loop_vertices[poly.loop_start[loop]:poly.loop_start[loop + 1]]]


def _host_frame(outer: np.ndarray) -> tuple[np.ndarray, np.ndarray, shapely.Polygon] | None:
    """(origin, 3 × 3 basis: two in-plane axes and the unit normal, the outline in the plane), None when degenerate."""
    origin = outer.mean(axis=0)
    frame = plane_frame(outer - origin)
    if frame is None:
        return None
    u, v = frame
    basis = np.stack([u, v, np.cross(u, v)], axis=1)
    return origin, basis, shapely.Polygon((outer - origin) @ basis[:, :2])


def misplaced_subsurfaces(poly: Polygons, planarity_tolerance: float,
                          merge_tolerance: float) -> tuple[list[dict], list[dict]]:
    """(subsurfaces off their host's plane or outside its outline: face, host, off_plane, outside — distances in the
    request's units; pairs of subsurfaces of one host that overlap: faces, host, overlap area)."""
    subs = np.flatnonzero(poly.face_parent >= 0)
    misplaced, overlaps = [], []
    by_host: dict[int, list[tuple[int, shapely.Polygon]]] = {}
    frames: dict[int, tuple | None] = {}
    for sub in subs.tolist():
        host = int(poly.face_parent[sub])
        if host not in frames:
            frames[host] = _host_frame(_outer(poly, host))
        frame = frames[host]
        if frame is None:
            continue
        origin, basis, outline = frame
        local = (_outer(poly, sub) - origin) @ basis
        off_plane = float(np.abs(local[:, 2]).max())
        points = shapely.points(local[:, :2])
        outside = float(shapely.distance(outline, points).max())
        # outside by more than either tolerance: an exporter's rounding puts a window's corner on its wall's edge
        if off_plane > planarity_tolerance or outside > max(merge_tolerance, planarity_tolerance):
            misplaced.append({"face": poly.face_ids[sub], "host": poly.face_ids[host], "off_plane": off_plane,
                              "outside": outside})
        else:
            # a self-intersecting window (corners in a bow-tie order) as the areas it covers, so its overlap is measured
            by_host.setdefault(host, []).append((sub, shapely.make_valid(shapely.Polygon(local[:, :2]))))
    for host, shapes in by_host.items():
        if len(shapes) < 2:
            continue
        polygons = [shape for _, shape in shapes]
        tree = shapely.STRtree(polygons)
        left, right = tree.query(polygons, predicate="intersects")
        once = left < right
        # a thousand copies of one window would be half a million pairs: the first are enough to name them
        for i, j in zip(left[once][:MAX_PAIRS].tolist(), right[once][:MAX_PAIRS].tolist(), strict=True):
            area = float(shapely.intersection(polygons[i], polygons[j]).area)
            if area > merge_tolerance * max(polygons[i].length, polygons[j].length):  # more than a shared edge
                overlaps.append({"faces": [poly.face_ids[shapes[i][0]], poly.face_ids[shapes[j][0]]],
                                 "host": poly.face_ids[host], "overlap_area": area})
    return misplaced, overlaps


def subsurface_warnings(poly: Polygons, planarity_tolerance: float, merge_tolerance: float,
                        units: str) -> list[Diagnostic]:
    """``subsurface_outside_host`` and ``subsurfaces_overlap``, naming the subsurfaces, their hosts and how far off
    (or how much area twice) in ``units``."""
    misplaced, overlaps = misplaced_subsurfaces(poly, planarity_tolerance, merge_tolerance)
    out = []
    if misplaced:
        listed = "; ".join(f"{m['face']!r} on {m['host']!r}: {m['off_plane']:.4g} {units} off its plane, "
                           f"{m['outside']:.4g} {units} outside its outline" for m in misplaced[:3])
        out.append(Diagnostic(code="subsurface_outside_host", message=(
            f"{len(misplaced)} window(s) or door(s) do not lie in their host face ({listed}"
            f"{' …' if len(misplaced) > 3 else ''}); their area is taken off the host's net_area all the same. Are "
            "they another face's, or in other coordinates (world over zone-relative)?"),
            details={"subsurfaces": misplaced[:MAX_LISTED], "count": len(misplaced), "units": units}))
    if overlaps:
        listed = "; ".join(f"{o['faces'][0]!r} and {o['faces'][1]!r} on {o['host']!r}: {o['overlap_area']:.4g} "
                           f"{units}²" for o in overlaps[:3])
        out.append(Diagnostic(code="subsurfaces_overlap", message=(
            f"{len(overlaps)} pair(s) of windows or doors overlap on their host ({listed}"
            f"{' …' if len(overlaps) > 3 else ''}): the host's net_area loses the overlap twice. Is one a copy?"),
            details={"pairs": overlaps[:MAX_LISTED], "count": len(overlaps), "units": units}))
    return out
