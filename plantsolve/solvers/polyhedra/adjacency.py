"""Multi-zone complexes: which zones share which faces, and how much area.

A face listed with two zones is one wall between them (α3 sews its two uses). Exporters that
write each side as a surface of its own (EnergyPlus interzone surfaces) give two coincident faces
in different zones: after merging, they have the same vertices, and they are paired here."""

from __future__ import annotations

from collections import defaultdict

import numpy as np

from plantsolve.solvers.polyhedra.polygons import Polygons


def adjacency(poly: Polygons, area: np.ndarray) -> list[dict]:
    """Shared faces per pair of zones: ``{"zones": [a, b], "faces": [...], "area": ...}``."""
    shared: dict[tuple[int, int], dict] = {}

    def add(pair: tuple[int, int], faces: list[int], face_area: float) -> None:
        entry = shared.setdefault(pair, {"faces": [], "area": 0.0})
        entry["faces"].extend(faces)
        entry["area"] += face_area

    fz = poly.face_zone
    for f in np.flatnonzero(fz[:, 1] >= 0):
        add((int(min(fz[f])), int(max(fz[f]))), [int(f)], float(area[f]))
    if len(poly.zone_ids) > 1:
        # a cheap signature (vertex count, sum, sum of squares of the vertex indices) finds the
        # candidates; the sorted vertex lists decide
        fps = poly.face_position_start
        single = (fz[:, 0] >= 0) & (fz[:, 1] < 0)
        position_face = poly.position_face
        lv = poly.loop_vertices.astype(np.float64)
        signature = np.stack([np.diff(fps), np.bincount(position_face, weights=lv, minlength=poly.n_faces),
                              np.bincount(position_face, weights=lv * lv, minlength=poly.n_faces)], axis=1)
        candidates = np.flatnonzero(single)
        _, inverse, counts = np.unique(signature[candidates], axis=0, return_inverse=True, return_counts=True)
        by_shape: dict[tuple, list[int]] = defaultdict(list)
        for f in candidates[counts[inverse.reshape(-1)] > 1].tolist():
            by_shape[tuple(np.sort(poly.loop_vertices[fps[f]:fps[f + 1]]).tolist())].append(f)
        for faces in by_shape.values():
            if len(faces) < 2:
                continue
            for i, a in enumerate(faces):
                for b in faces[i + 1:]:
                    za, zb = int(fz[a, 0]), int(fz[b, 0])
                    if za != zb:
                        add((min(za, zb), max(za, zb)), [a, b], float(area[a]))
    out = []
    for (za, zb), entry in sorted(shared.items(), key=lambda item: (poly.zone_ids[item[0][0]], poly.zone_ids[item[0][1]])):
        names = sorted([poly.zone_ids[za], poly.zone_ids[zb]])
        out.append({"zones": names, "faces": [poly.face_ids[f] for f in entry["faces"]], "area": entry["area"]})
    return out
