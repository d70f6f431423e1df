"""Finite-element reference for patch electrodes of finite length (scikit-fem, P1 tetrahedra, pyamg).

Model (the seed's sections 1-2, eq. 4): the virtual-current potential phi is harmonic in the liner
section |z| < L/2 of the pipe r < R; phi = V on the electrode patch |theta| < beta, |z| < a (the
equipotential, Dirichlet electrode of eq. 4), -V on the opposite one, d(phi)/dn = 0 on the rest of
the wall and on the end cross-sections (the liner section is insulated; the current that the
metal pipe beyond the liner would draw is not modelled). By the symmetries of the seed's
section 4.2 only the eighth x, y, z >= 0 is meshed, with phi = 0 on the plane x = 0 (the seed's
"Y-Z plane at zero potential") and no normal current through y = 0 and z = 0.

With I the current through the whole electrode (four times the eighth's),
W(x, y) = (pi R / 2) integral_{-L/2}^{L/2} d(phi)/dx dz / I (conductivity 1), the seed's eq. 35 in
the normalisation S = (1/(pi R^2)) integral W dA, and S = integral_eighth d(phi)/dx dV / (R I_eighth).

The mesh is an extrusion of a ring-by-ring triangulation of the quarter disc, graded towards the
electrode edges (theta = beta on the wall and z = a), where the potential has its square-root
singularity; each prism is split into three tetrahedra by the global-index rule, which keeps
the split faces of neighbouring prisms conforming. Lengths are in units of R.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
import pyamg
from scipy.sparse.linalg import spsolve
from skfem import Basis, ElementTetP1, MeshTet, asm
from skfem.models.poisson import laplace


QUADRANTS = ((1, 1), (-1, 1), (1, -1), (-1, -1))  # signs of (x, y)


@dataclass
class FemSolution:
    sensitivity: float
    triangles: np.ndarray  # (m, 3) node indices of the quarter-disc triangulation
    nodes: np.ndarray  # (n, 2) quarter-disc nodes (x, y) in units of R
    weight: np.ndarray  # (4, m) W on each triangle (its mean) in the quadrants QUADRANTS
    unknowns: int
    tetrahedra: int


def graded_points(start: float, stop: float, spacing, fine: int = 4000) -> np.ndarray:
    """Points from ``start`` to ``stop`` (both included) whose spacing follows ``spacing(s)``."""
    s = np.linspace(start, stop, fine)
    density = 1.0 / spacing(s)
    cumulative = np.concatenate([[0.0], np.cumsum(0.5 * (density[1:] + density[:-1]) * np.diff(s))])
    count = max(int(np.ceil(cumulative[-1])), 1)
    return np.interp(np.linspace(0.0, cumulative[-1], count + 1), cumulative, s)


def graded_with_break(start: float, stop: float, at: float, spacing) -> np.ndarray:
    """Graded points with ``at`` (strictly inside) among them."""
    if not start < at < stop:
        return graded_points(start, stop, spacing)
    return np.concatenate([graded_points(start, at, spacing)[:-1], graded_points(at, stop, spacing)])


def axial_spacing(distance: np.ndarray, h: float, h_edge: float, grade: float) -> np.ndarray:
    """Layer spacing at a distance from the electrode's end: graded to it, h within a radius of it,
    then growing in proportion to the distance (up to 2 R): the potential there varies like
    exp(-1.84 |z| / R), the slowest decaying mode, so long liners cost few layers."""
    near = np.minimum(h, h_edge + grade * distance)
    return np.clip(np.maximum(near, 0.25 * (distance - 1.0)), None, 2.0)


def quarter_disc(beta: float, h: float, h_edge: float, grade: float,
                 footprint: tuple[float, float] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Nodes and triangles of the quarter disc x, y >= 0, graded towards the wall point at angle beta.

    ``footprint = (half_width, protrusion)`` grades towards a button instead: the part of the
    cross-section a button electrode of radius ``half_width`` protruding ``protrusion`` into the
    flow covers at some z (0 <= y <= half_width, x >= 1 - protrusion, the wall arc up to
    asin(half_width)); the spacing there is ``h_edge`` throughout, because the electrode's edge
    (a circle in y-z) crosses every cross-section over that range."""
    edge = np.array([np.cos(beta), np.sin(beta)])

    def distance(px, py):
        if footprint is None:
            return np.hypot(px - edge[0], py - edge[1])
        width, protrusion = footprint
        # distance to the wall arc the face covers (0 <= theta <= asin(width)) ...
        rho, phi = np.hypot(px, py), np.arctan2(py, px)
        arc = np.where(phi <= beta, 1.0 - rho, np.hypot(px - edge[0], py - edge[1]))
        if protrusion == 0:
            return arc
        # ... and to the protruding part, the box 0 <= y <= width, x >= 1 - protrusion
        box = np.hypot(np.maximum(1.0 - protrusion - px, 0.0), np.maximum(py - width, 0.0))
        return np.minimum(arc, box)

    def radial_spacing(r):
        near = 1.0 - r if footprint is None else np.maximum(1.0 - footprint[1] - r, 0.0)
        return np.minimum(h, h_edge + grade * near)

    # a ring through the tip of a protruding button (x = 1 - protrusion at theta = 0)
    tip = 1.0 - footprint[1] if footprint is not None and footprint[1] > 0 else 1.0
    radii = graded_with_break(0.0, 1.0, tip, radial_spacing)
    nodes = [np.zeros((1, 2))]
    rings = [np.array([0])]
    count = 1
    for r in radii[1:]:
        def arc_spacing(t, r=r):
            return np.minimum(h, h_edge + grade * distance(r * np.cos(t), r * np.sin(t))) / r

        theta = graded_with_break(0.0, np.pi / 2, beta, arc_spacing)
        if len(theta) < 3:
            theta = np.linspace(0.0, np.pi / 2, 3)
        ring = np.column_stack([r * np.cos(theta), r * np.sin(theta)])
        ring[-1, 0] = 0.0  # exactly on the plane x = 0, where phi = 0 is imposed
        ring[0, 1] = 0.0
        nodes.append(ring)
        rings.append(count + np.arange(len(theta)))
        count += len(theta)
    points = np.vstack(nodes)
    angle = np.arctan2(points[:, 1], points[:, 0])
    triangles = []
    for inner, outer in zip(rings[:-1], rings[1:]):
        if len(inner) == 1:
            triangles += [(inner[0], outer[j], outer[j + 1]) for j in range(len(outer) - 1)]
            continue
        i = j = 0
        while i < len(inner) - 1 or j < len(outer) - 1:
            advance_outer = i == len(inner) - 1 or (j < len(outer) - 1 and angle[outer[j + 1]] <= angle[inner[i + 1]])
            if advance_outer:
                triangles.append((inner[i], outer[j], outer[j + 1]))
                j += 1
            else:
                triangles.append((inner[i], outer[j], inner[i + 1]))
                i += 1
    return points, np.array(triangles)


def extrude(points: np.ndarray, triangles: np.ndarray, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Tetrahedra of the prisms over ``triangles`` between consecutive ``z`` levels."""
    n = len(points)
    xyz = np.column_stack([np.tile(points, (len(z), 1)), np.repeat(z, n)])
    ordered = np.sort(triangles, axis=1)
    i, j, k = ordered.T
    tets = []
    for layer in range(len(z) - 1):
        lo, hi = layer * n, (layer + 1) * n
        # diagonal of each side face from its lower-index bottom node to its higher-index top node
        tets += [np.column_stack([i + lo, j + lo, k + lo, k + hi]),
                 np.column_stack([i + lo, j + lo, j + hi, k + hi]),
                 np.column_stack([i + lo, i + hi, j + hi, k + hi])]
    return xyz, np.vstack(tets)


def solve_patch(beta: float, half_length: float, half_liner: float, h: float = 0.12,
                edge_ratio: float = 0.08, grade: float = 0.35,
                field: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]] | None = None) -> FemSolution:
    """S, W per triangle and the electrode current for a patch (half-angle ``beta`` radians,
    half-length ``half_length``) in an insulated liner section of half-length ``half_liner`` (R = 1).

    ``field(points) -> (B_x, B_y)`` (relative to the reference B) at points (n, 3); None is the
    uniform field along +y. The potential on the other seven eighths follows from the symmetries
    (odd in x, even in y and z): there d(phi)/dx is the same and d(phi)/dy carries the signs of x and y."""
    h_edge = h * edge_ratio
    points, triangles = quarter_disc(beta, h, h_edge, grade)
    a = min(half_length, half_liner)
    z = graded_with_break(0.0, half_liner, a, lambda s: axial_spacing(np.abs(s - a), h, h_edge, grade))
    radius = np.hypot(points[:, 0], points[:, 1])
    angle = np.arctan2(points[:, 1], points[:, 0])
    on_electrode_2d = (radius > 1 - 1e-9) & (angle <= beta + 1e-9)
    electrode = np.tile(on_electrode_2d, len(z)) & (np.repeat(z, len(points)) <= a + 1e-9)
    return solve_mesh(points, triangles, z, electrode, field)


def button_edge_size(radius: float, h: float, edge_ratio: float = 0.08) -> float:
    """The mesh spacing over a button: the patch's edge spacing, and at most h / 1.5 of the radius (12
    cells across it at h = 0.12 R), so that the staircase boundary refines with the mesh."""
    return min(h * edge_ratio, radius * h / 1.5)


def solve_button(radius: float, protrusion: float, half_liner: float, h: float = 0.12,
                 edge_ratio: float = 0.08, grade: float = 0.35,
                 field: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]] | None = None) -> FemSolution:
    """A button electrode (the seed's sketch): a cylinder of radius ``radius`` along x through the wall
    at (1, 0, 0), entering the flow by ``protrusion`` (0: a flush disc), equipotential. Its surface is
    the wall inside y^2 + z^2 <= radius^2 and, protruding, the solid y^2 + z^2 <= radius^2,
    x >= 1 - protrusion; the nodes inside it are held at the electrode potential (a staircase
    boundary on the structured mesh, first order in the spacing ``button_edge_size``)."""
    h_edge = button_edge_size(radius, h, edge_ratio)
    points, triangles = quarter_disc(float(np.arcsin(min(radius, 1.0))), h, h_edge, grade,
                                     footprint=(radius, protrusion))
    z = graded_with_break(0.0, half_liner, radius,
                          lambda s: axial_spacing(np.maximum(s - radius, 0.0), h, h_edge, grade))
    n2 = len(points)
    x, y = np.tile(points[:, 0], len(z)), np.tile(points[:, 1], len(z))
    zz = np.repeat(z, n2)
    inside = y * y + zz * zz <= radius * radius * (1 + 1e-9)
    wall = np.tile(np.hypot(points[:, 0], points[:, 1]) > 1 - 1e-9, len(z))
    electrode = inside & (wall | (x >= 1 - protrusion - 1e-12))
    return solve_mesh(points, triangles, z, electrode, field)


# relative residual the multigrid solve must reach; above it the direct solve is taken instead (an S read off an
# unconverged potential would be wrong by an amount no error estimate of the mesh sees)
AMG_RESIDUAL = 1e-8


def potential(a_ff, rhs: np.ndarray, amg_from: int = 3000) -> np.ndarray:
    """The free nodes' potential: multigrid-preconditioned CG on large systems, checked by its residual (pyamg
    stops at ``maxiter`` without a word), the direct solve on small ones and where CG did not converge."""
    if a_ff.shape[0] >= amg_from:
        solver = pyamg.smoothed_aggregation_solver(a_ff, symmetry="symmetric")
        x = solver.solve(rhs, tol=1e-11, accel="cg", maxiter=400)
        scale = float(np.linalg.norm(rhs)) or 1.0
        if np.all(np.isfinite(x)) and float(np.linalg.norm(rhs - a_ff @ x)) <= AMG_RESIDUAL * scale:
            return x
    return spsolve(a_ff.tocsc(), rhs)


def solve_mesh(points: np.ndarray, triangles: np.ndarray, z: np.ndarray, electrode: np.ndarray,
               field: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]] | None) -> FemSolution:
    """The potential on the extruded mesh with ``electrode`` nodes at 1 and the plane x = 0 at 0;
    S and W per cross-section triangle."""
    xyz, tets = extrude(points, triangles, z)
    mesh = MeshTet(xyz.T.copy(), tets.T.copy())
    basis = Basis(mesh, ElementTetP1())
    stiffness = asm(laplace, basis).tocsr()

    grounded = np.tile(points[:, 0] == 0.0, len(z))
    fixed = electrode | grounded
    phi = np.where(electrode, 1.0, 0.0)
    free = ~fixed
    a_ff = stiffness[free][:, free].tocsr()
    rhs = -stiffness[free][:, fixed] @ phi[fixed]
    phi[free] = potential(a_ff, rhs)
    reaction = stiffness @ phi
    current = float(np.sum(reaction[electrode]))  # the discrete flux out of the electrode (eighth)

    corners = xyz[tets]  # (m, 4, 3)
    edges = corners[:, 1:, :] - corners[:, :1, :]
    det = np.linalg.det(edges)
    volume = np.abs(det) / 6.0
    # gradient of the P1 function: solve edges @ g = phi differences
    dphi = phi[tets[:, 1:]] - phi[tets[:, :1]]
    gradient = np.linalg.solve(edges, dphi[..., None])[..., 0]
    m2 = len(triangles)
    layers = len(z) - 1
    tri_pts = points[triangles]
    area = 0.5 * np.abs((tri_pts[:, 1, 0] - tri_pts[:, 0, 0]) * (tri_pts[:, 2, 1] - tri_pts[:, 0, 1])
                        - (tri_pts[:, 2, 0] - tri_pts[:, 0, 0]) * (tri_pts[:, 1, 1] - tri_pts[:, 0, 1]))
    centroid = corners.mean(axis=1)
    weight = np.empty((4, m2))
    for q, (sx, sy) in enumerate(QUADRANTS):
        total = np.zeros(len(tets))
        for sz in (1, -1):
            if field is None:
                bx, by = 0.0, 1.0
            else:
                bx, by = field(centroid * np.array([sx, sy, sz]))
            total += volume * (by * gradient[:, 0] - bx * sx * sy * gradient[:, 1])
        # W = (pi R / 2) integral dz / I with I = 4 I_eighth, the two z-halves summed above
        weight[q] = (np.pi / 8) * total.reshape(layers, 3, m2).sum(axis=(0, 1)) / area / current
    sensitivity = float(np.sum(weight * area) / np.pi)

    return FemSolution(sensitivity, triangles, points, weight, int(np.sum(free)), len(tets))
