"""The flowmeter job: virtual current -> weight function -> sensitivity, probes and linearity.

Stages (the seed's Siemens chapter): the virtual current of the electrodes (sections 1-3), the
weight function W integrated along z (section 8, eq. 35) and its integrals with the flow profile
(eq. 34, 39), over a list of Reynolds numbers for the linearity curve.

Everything is computed for R = 1 and scaled back: S and W(x/R, y/R) depend only on the electrode
half-angle, a/R and L/R (and on the shapes of field and profile), the seed's scaling question.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
from matplotlib.tri import LinearTriInterpolator, Triangulation

from plantsolve.schemas.common import Diagnostic, Report
from plantsolve.schemas.flowmeter import FlowmeterRequest, FlowmeterResult, LinearityPoint
from plantsolve.solvers.base import Progress, Solved, no_progress
from plantsolve.solvers.flowmeter import fem, grid_weight, integral_equation, integral_equation_button, profiles, weight2d
from plantsolve.solvers.flowmeter.field import FieldGrid, field_grid, request_field
from plantsolve.solvers.flowmeter.plausibility import METRES, request_warnings, signal_warnings
from plantsolve.solvers.flowmeter.validation import meter_shape

GRID_SIZE = 41
WALL_NODES = 4 * GRID_SIZE  # the grid's ring on the wall: its plot and table reach the wall


@dataclass
class WeightField:
    """A cross-section weight function on the unit disc and how to integrate it."""

    method: str
    values: Callable[[np.ndarray, np.ndarray], np.ndarray]
    integrate: Callable[[Callable[[np.ndarray, np.ndarray], np.ndarray]], float]
    error_estimate: float
    electrode_current: np.ndarray  # rows (theta rad, j R / I)
    details: dict
    current_map: np.ndarray | None = None  # rows (theta rad, z / R, j R^2 / I) over the electrode


def quadrature_field(method: str, values, current: np.ndarray, details: dict) -> WeightField:
    """A closed-form W integrated with the polar rule; the error estimate is the change from a rule of
    half the resolution."""
    fine = profiles.disc_quadrature(radial=64, scale=40.0, max_angular=40000)
    coarse = profiles.disc_quadrature(radial=40, scale=20.0, max_angular=10000)
    w_fine, w_coarse = values(fine.x, fine.y), values(coarse.x, coarse.y)

    def integrate(velocity) -> float:
        return float(np.sum(w_fine * velocity(fine.x, fine.y) * fine.w) / np.pi)

    uniform_fine = float(np.sum(w_fine * fine.w) / np.pi)
    uniform_coarse = float(np.sum(w_coarse * coarse.w) / np.pi)
    return WeightField(method, values, integrate, abs(uniform_fine - uniform_coarse), current, details)


def edge_nodes(beta: float, count: int = 64) -> np.ndarray:
    """Angles in (-beta, beta) clustered at the edges (Chebyshev points), where the current peaks."""
    return beta * np.cos(np.pi * (np.arange(count) + 0.5) / count)[::-1]


def combine(complex_weight, average):
    """W for a field: Re of the complex weight for B along +y; with a grid, weighted by the liner's
    mean B_y and B_x (module field)."""
    if average is None:
        return lambda x, y: np.real(complex_weight(x, y))

    def values(x, y):
        c = complex_weight(x, y)
        bx, by = average(x, y)
        return by * np.real(c) + bx * np.imag(c)

    return values


def closed_form(beta: float | None, method: str, average=None) -> WeightField:
    """Full-length equipotential, point, or first-order electrodes in closed form (module weight2d)."""
    if beta is None:
        return quadrature_field("closed_form_point", weight2d.weight_point, np.zeros((0, 2)),
                                {"model": "point electrodes, Shercliff's weight function"})
    theta = edge_nodes(beta)
    if method == "first_order":
        current = np.column_stack([theta, np.full_like(theta, 1 / (2 * beta))])
        field = quadrature_field("first_order", combine(lambda x, y: weight2d.complex_weight_first_order(x, y, beta), average),
                                 current, {"model": "uniform current density on the electrodes (the seed's first-order iterate)"})
        # The iterate's error is that of its model, not of the quadrature: its distance from the
        # exact equipotential value for full-length electrodes (the 3-D gap is smaller).
        model_gap = weight2d.sensitivity_first_order(beta) - np.pi / 2 / weight2d.electrode_current_integral(beta)
        field.error_estimate += abs(model_gap)
        field.details["model_error_estimate"] = abs(model_gap)
        return field
    integral = weight2d.electrode_current_integral(beta)
    density = 1 / (2 * np.sqrt(np.sin(beta) ** 2 - np.sin(theta) ** 2)) / integral
    return quadrature_field("closed_form_2d", combine(lambda x, y: weight2d.complex_weight_full_length(x, y, beta), average),
                            np.column_stack([theta, density]),
                            {"model": "equipotential electrodes along the whole liner (2-D, exact)"})


def mesh_size(tolerance: float) -> float:
    """FEM mesh size (units of R) for a target accuracy of S; measured on the test geometry the
    calibrated S changes by less than 2e-4 between 0.25 and 0.08."""
    return float(np.clip(0.12 * np.sqrt(tolerance / 1e-3), 0.08, 0.25))


def finite_elements(beta: float | None, a: float, half_liner: float, tolerance: float, progress: Progress,
                    grid: FieldGrid | None = None, button: tuple[float, float] | None = None) -> WeightField:
    """FEM reference (module fem). Patches are calibrated by the exact 2-D value: the ratio of the exact
    full-length S to the FEM's (uniform field) on the same cross-section mesh multiplies S and W,
    removing most of the error of the theta-edge singularity and of the polygonal wall. Buttons
    have no such companion and are reported uncalibrated. The change of S between the mesh and one
    1.5 times coarser is the error estimate."""
    h = mesh_size(tolerance)
    at = None if grid is None else grid.at
    runs = []
    for step, size in enumerate((1.5 * h, h)):
        progress(0.1 + 0.35 * step, f"finite elements, mesh size {size:.3g} R")
        if button is not None:
            patch = fem.solve_button(*button, half_liner, h=size, field=at)
            runs.append((patch, None, 1.0))
            continue
        patch = fem.solve_patch(beta, a, half_liner, h=size, field=at)
        progress(0.25 + 0.35 * step, f"finite elements, full-length companion for the calibration, mesh size {size:.3g} R")
        full = fem.solve_patch(beta, half_liner, half_liner, h=size)
        exact_2d = np.pi / 2 / weight2d.electrode_current_integral(beta)
        runs.append((patch, full, exact_2d / full.sensitivity))
    progress(0.8, "finite elements: weight function")
    patch, full, ratio = runs[-1]
    coarse_patch, _, coarse_ratio = runs[0]
    calibrated = patch.sensitivity * ratio
    error = abs(calibrated - coarse_patch.sensitivity * coarse_ratio)
    if button is not None:  # uncalibrated, first order in h: the error is about twice the change from 1.5 h
        error *= 2
    elif grid is not None:
        # the calibration is exact for a uniform field only: in a grid field the FEM converges at about
        # first order (measured against the integral equation), and the calibration's own size counts
        error = 2 * error + abs(ratio - 1) * abs(calibrated)
    weight = patch.weight * ratio
    tri = Triangulation(patch.nodes[:, 0], patch.nodes[:, 1], patch.triangles)
    finder = tri.get_trifinder()
    corners = patch.nodes[patch.triangles]
    u, v = corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]
    area = 0.5 * np.abs(u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0])
    midpoints = [(corners[:, i] + corners[:, (i + 1) % 3]) / 2 for i in range(3)]
    # W at the nodes (area-weighted mean of the triangles around each), linear in between: the
    # piecewise-constant W integrates consistently but draws jagged contours
    share = np.zeros(len(patch.nodes))
    for k in range(3):
        np.add.at(share, patch.triangles[:, k], area)
    nodal = np.zeros((4, len(patch.nodes)))
    for q in range(4):
        for k in range(3):
            np.add.at(nodal[q], patch.triangles[:, k], weight[q] * area)
    nodal /= share
    interpolators = [LinearTriInterpolator(tri, nodal[q], trifinder=finder) for q in range(4)]

    def values(x, y):
        x, y = np.asarray(x, float), np.asarray(y, float)
        ax, ay = np.abs(x), np.abs(y)
        out = np.full(x.shape, np.nan)
        for q, (sx, sy) in enumerate(fem.QUADRANTS):
            mine = ((x >= 0) if sx > 0 else (x < 0)) & ((y >= 0) if sy > 0 else (y < 0))
            if np.any(mine):
                out[mine] = np.ma.filled(interpolators[q](ax[mine], ay[mine]), np.nan)
                missing = mine & ~np.isfinite(out)
                if np.any(missing):  # between the polygonal wall and the circle: the nearest node
                    near = np.argmin((patch.nodes[:, 0][None] - ax[missing][:, None]) ** 2
                                     + (patch.nodes[:, 1][None] - ay[missing][:, None]) ** 2, axis=1)
                    out[missing] = nodal[q][near]
        return out

    def integrate(velocity) -> float:
        total = 0.0
        for q, (sx, sy) in enumerate(fem.QUADRANTS):
            v = sum(velocity(sx * m[:, 0], sy * m[:, 1]) for m in midpoints) / 3
            total += float(np.sum(weight[q] * v * area))
        return total / np.pi

    # For a uniform field W is harmonic in this model (the z-integrated potential has no z-flux
    # through the insulated ends), so every axisymmetric profile has the same S: the
    # laminar-uniform difference measures the discretisation error of W itself.
    # A protruding button takes fluid out of the disc: W is harmonic only in what is left, and the
    # profile matters for real (the electrode weighs the flow where it reaches into it).
    if grid is None and (button is None or button[1] == 0):
        laminar = integrate(lambda x, y: profiles.axisymmetric("laminar", np.hypot(x, y)))
        error = max(error, abs(laminar - integrate(lambda x, y: np.ones_like(x))))
    # No current density: the lumped nodal reaction misstates it on the symmetry planes (by about
    # 4/3 at the electrode centre against the exact 2-D density), so none is reported.
    model = ("equipotential button electrodes (radius, protrusion) on an insulated liner section (ends insulated), "
             "FEM, staircase electrode boundary" if button is not None else
             "equipotential patches on an insulated liner section (ends insulated), FEM")
    return WeightField("fem", values, integrate, error, np.zeros((0, 2)),
                       {"mesh_size": h, "unknowns": patch.unknowns, "tetrahedra": patch.tetrahedra,
                        "uncalibrated_sensitivity": patch.sensitivity, "calibration_ratio": ratio, "model": model})


def integral_equation_field(beta: float, a: float, half_liner: float, tolerance: float,
                            button: float | None = None, progress: Progress | None = None,
                            grid: FieldGrid | None = None) -> WeightField:
    """The integral equation on the electrode (modules integral_equation, integral_equation_button): S
    extrapolated in the modes, W from its series, integrated ring by ring on the polar rule (exact
    values of the series there)."""
    if button is None:
        solution = integral_equation.solve_patch(beta, a, half_liner, tolerance, progress)

        def density(theta, z=None, coefficients=None):
            return integral_equation.current_density(solution, beta, theta, z, a, coefficients)

        width, model = beta, ("equipotential patches on an insulated liner section (ends insulated), "
                              "Galerkin integral equation on the electrode")
    else:
        solution = integral_equation_button.solve_button(button, half_liner, tolerance, progress=progress)

        def density(theta, z=None, coefficients=None):
            return integral_equation_button.current_density(solution, button, theta, z, coefficients)

        width, model = float(np.arcsin(button)), ("equipotential flush buttons on an insulated liner section (ends "
                                                  "insulated), Galerkin integral equation on the electrode")
    # The density converges like 1/M (slower than S, whose error is second order): Richardson over the
    # two finest levels on the coefficients, as on S (the total current stays 1); its change from the
    # finest level, on the part without the edge singularity, is the density's error estimate.
    extrapolated = 2 * solution.coefficients - solution.previous_coefficients
    theta = edge_nodes(width)
    current = np.column_stack([theta, density(theta, coefficients=extrapolated)])
    smooth = np.sqrt(1 - (theta / width) ** 2)
    change = float(np.max(np.abs(density(theta) - current[:, 1]) * smooth) / np.max(np.abs(current[:, 1]) * smooth))
    current_map = electrode_map(lambda t, z: density(t, z, extrapolated), width, a if button is None else button,
                                button is not None)
    if grid is not None:
        field = integral_equation_in_grid(solution, grid, current, model, progress)
        field.current_map, field.details["electrode_current_change"] = current_map, change
        return field
    if progress is not None:
        progress(0.8, "integral equation: weight function on the cross-section")
    quadrature = profiles.disc_quadrature(radial=64, scale=40.0, max_angular=40000)
    rings = np.concatenate([integral_equation.weight_on_ring(solution.series, r, count) for r, count in quadrature.rings])

    def integrate(velocity) -> float:
        return float(np.sum(rings * velocity(quadrature.x, quadrature.y) * quadrature.w) / np.pi)

    # the rule's own error: its uniform-flow integral against W(0), equal for a harmonic W
    error = solution.error_estimate + abs(integrate(lambda x, y: np.ones_like(x)) - solution.sensitivity)
    return WeightField("integral_equation", lambda x, y: integral_equation.weight_at(solution.series, x, y),
                       integrate, error, current,
                       {"modes": solution.levels, "basis": solution.basis, "model": model,
                        "electrode_current_change": change}, current_map)


def electrode_map(density, width: float, half_length: float, disc: bool, count: int = 25) -> np.ndarray:
    """The density on Chebyshev points over the electrode: rows (theta rad, z / R, j R^2 / I); for a
    button the z points of each theta span its chord of the disc."""
    nodes = np.cos(np.pi * (np.arange(count) + 0.5) / count)
    theta = width * nodes
    rows = []
    for t in theta:
        reach = np.sqrt(max(half_length**2 - np.sin(t) ** 2, 0.0)) if disc else half_length
        z = reach * nodes
        rows.append(np.column_stack([np.full(count, t), z, density(np.full(count, t), z)]))
    return np.vstack(rows)


def integral_equation_in_grid(solution, grid: FieldGrid, current: np.ndarray, model: str,
                              progress: Progress | None) -> WeightField:
    """W in a grid field from the integral equation's current (module grid_weight): the z-mean field
    on the z-integrated series (fine rule) plus the modes of the field's variation along z (light rule)."""
    extra = grid_weight.grid_weight(solution, grid, progress)
    if progress is not None:
        progress(0.8, "integral equation: z-mean field on the cross-section")
    fine = profiles.disc_quadrature(radial=64, scale=40.0, max_angular=40000)
    c = np.concatenate([integral_equation.complex_on_ring(solution.series, r, count) for r, count in fine.rings])
    pts = np.column_stack([fine.x, fine.y])
    w0 = extra.mean_by(pts) * c.real + extra.mean_bx(pts) * c.imag
    light = extra.quadrature

    def integrate(velocity) -> float:
        return float((np.sum(w0 * velocity(fine.x, fine.y) * fine.w)
                      + np.sum(extra.values * velocity(light.x, light.y) * light.w)) / np.pi)

    def values(x, y):
        x, y = np.asarray(x, float), np.asarray(y, float)
        at = np.column_stack([np.ravel(x), np.ravel(y)])
        cz = integral_equation.complex_weight_at(solution.series, x, y)
        base = extra.mean_by(at).reshape(x.shape) * cz.real + extra.mean_bx(at).reshape(x.shape) * cz.imag
        return base + grid_weight.interpolate_rings(light, extra.values, np.ravel(x), np.ravel(y)).reshape(x.shape)

    s = integrate(lambda x, y: np.ones_like(x))
    truncation = abs(float(np.sum((extra.values - extra.half_values) * light.w) / np.pi))
    # the uniform-field estimate, scaled to this field, plus the truncation of the field's z modes
    error = solution.error_estimate * abs(s) / max(solution.sensitivity, 1e-300) + truncation
    return WeightField("integral_equation", values, integrate, error, current,
                       {"modes": solution.levels, "basis": solution.basis, "field_z_modes": int(solution.wall.shape[1]),
                        "field_z_truncation": truncation, "model": model + ", in the grid field (z modes of B)"})


def virtual_current(request: FlowmeterRequest, progress: Progress, grid: FieldGrid | None = None) -> WeightField:
    """Sections 1-3: the virtual current of the electrodes, as its cross-section weight function (``grid``: the
    request's field on its grid, if not uniform)."""
    g = meter_shape(request)
    average = None if grid is None else grid.liner_average(g.half_liner)
    method = request.options.method
    if g.button is not None:
        r_e, l_e = g.button
        flush_ie = l_e == 0 and integral_equation_button.feasible(r_e, g.half_liner, request.options.tolerance)
        if method == "integral_equation" or (method == "auto" and flush_ie):
            progress(0.1, "integral equation on the button")
            return integral_equation_field(0.0, 0.0, g.half_liner, request.options.tolerance, r_e, progress, grid)
        return finite_elements(None, 0.0, g.half_liner, request.options.tolerance, progress, grid, g.button)
    if g.beta is None:
        return closed_form(None, method)
    if method == "first_order":
        return closed_form(g.beta, "first_order", average)
    if method == "auto" and g.full_length:
        return closed_form(g.beta, "exact", average)
    if method == "integral_equation" or (method == "auto" and integral_equation.feasible(g.beta, g.half_length, g.half_liner)):
        progress(0.1, "integral equation on the electrode")
        return integral_equation_field(g.beta, g.half_length, g.half_liner, request.options.tolerance,
                                       progress=progress, grid=grid)
    return finite_elements(g.beta, g.half_length, g.half_liner, request.options.tolerance, progress, grid)


def velocity_function(request: FlowmeterRequest) -> tuple[Callable, str, list[Diagnostic]]:
    """v / v_mean on the unit disc for the request's profile."""
    spec = request.velocity
    notes: list[Diagnostic] = []
    if spec.type != "samples":
        return (lambda x, y: profiles.axisymmetric(spec.type, np.hypot(x, y), spec.n)), spec.type, notes
    radius = request.pipe.radius
    points = np.asarray(spec.points, dtype=float)[:, :2] / radius
    velocity, covered = profiles.sampled(points, np.asarray(spec.values, dtype=float))
    if covered < 0.999:
        notes.append(Diagnostic(code="samples_do_not_reach_the_wall",
                                message=f"The samples' triangulation covers {100 * covered:.1f} % of the cross-section; "
                                        "the nearest sample's value is used outside it.",
                                details={"covered_fraction": covered}))
    return velocity, "samples", notes


# An error estimate is the change between two meshes or mode levels: good to about a factor of two, so that the FEM's
# mesh rule, aimed at the target, lands on either side of it (1.0009e-3 for 1e-3 on full-length electrodes, 4e-4 off)
ESTIMATE_SLACK = 2.0


def tolerance_missed(field: WeightField, tolerance: float) -> Diagnostic | None:
    """The warning of a sensitivity whose estimated error exceeds options.tolerance (by more than the estimate's own
    uncertainty), None when it is within: the finite-element mesh stops at its finest size, the first-order iterate is
    an approximation of fixed accuracy, and the result said 'ok' beside an error 13 or 500 times the target."""
    if not field.error_estimate > ESTIMATE_SLACK * tolerance:
        return None
    return Diagnostic(
        code="tolerance_not_reached", message=f"The estimated error of S, {field.error_estimate:.2g}, is above "
        f"options.tolerance ({tolerance:.2g}): the method '{field.method}' reaches no closer here"
        + (" (its finest mesh)" if field.method == "fem" else "") + "; S and the linearity curve are that uncertain. "
        "Method 'auto' or 'integral_equation' reaches tighter tolerances for patches and flush buttons.",
        details={"quantity": "sensitivity", "error_estimate": field.error_estimate, "tolerance": tolerance,
                 "method": field.method})


def sensitivity(field: WeightField, velocity) -> tuple[float, float]:
    """Eq. 34 normalised: S = integral W v dA / integral v dA; returns (S, mean of v over the disc)."""
    quadrature = profiles.disc_quadrature(radial=48, scale=4.0, max_angular=2048)
    mean = float(np.sum(velocity(quadrature.x, quadrature.y) * quadrature.w) / np.pi)
    return field.integrate(velocity) / mean, mean


def ideal_meter_residual(field: WeightField, s_uniform: float) -> float:
    """Bevir's ideal-meter condition for rectilinear flow: with the weight vector W_z(x, y) e_z, curl W = 0
    means W constant over the cross-section (every profile then gives the same signal). Returned as
    (1/(pi R^2)) integral |W - S| dA / |S|, the mean deviation (finite also where W is unbounded at
    point electrodes, unlike an L2 norm); 0 for an ideal meter."""
    quadrature = profiles.disc_quadrature(radial=48, scale=10.0, max_angular=4096)
    w = field.values(quadrature.x, quadrature.y)
    return float(np.sum(np.abs(w - s_uniform) * quadrature.w) / np.pi / abs(s_uniform))


def linearity(field: WeightField, reynolds: list[float]) -> list[LinearityPoint]:
    """S over Reynolds numbers, the profile going from laminar to the turbulent power law."""
    out = []
    for re in reynolds:
        kind, n = profiles.profile_for_reynolds(re)
        s = field.integrate(lambda x, y: profiles.axisymmetric(kind, np.hypot(x, y), n))
        out.append(LinearityPoint(reynolds=re, profile=kind, n=n, sensitivity=s))
    return out


def cross_section_nodes() -> tuple[np.ndarray, np.ndarray]:
    """Nodes of the W table on the unit disc: a square grid inside and a ring on the wall (a hair inside, where W
    is finite off the electrode edges), so that the table and its plot cover the section up to the wall; the
    ring's angles are offset by half a step from the electrodes' centres (0 and 180 degrees), where the W of point
    electrodes is unbounded."""
    axis = np.linspace(-1, 1, GRID_SIZE)
    gx, gy = np.meshgrid(axis, axis)
    inside = np.hypot(gx, gy) < 1 - 1e-9
    angles = 2 * np.pi * (np.arange(WALL_NODES) + 0.5) / WALL_NODES
    wall = 1 - 1e-6
    return (np.concatenate([gx[inside], wall * np.cos(angles)]), np.concatenate([gy[inside], wall * np.sin(angles)]))


def solve(request: FlowmeterRequest, progress: Progress = no_progress) -> Solved:
    """The job on a checked request (``check_input``)."""
    g = meter_shape(request)
    radius = request.pipe.radius
    given = request_field(request)
    grid = field_grid(request, given)
    progress(0.05, "virtual current")
    field = virtual_current(request, progress, grid)
    progress(0.85, "weight function integrals: the request's profile")
    velocity, profile, notes = velocity_function(request)
    s, mean = sensitivity(field, velocity)
    progress(0.9, "probes, the weight-function grid and the linearity curve")
    mean_velocity = request.velocity.mean if profile != "samples" else mean
    b = request.magnetic_field.magnitude if grid is None else grid.reference
    signal = 2 * radius * METRES[request.units] * b * mean_velocity * s
    probes = []
    if request.options.probe_points:
        pts = np.asarray([p[:2] for p in request.options.probe_points], dtype=float) / radius
        probes = [float(v) for v in field.values(pts[:, 0], pts[:, 1])]
    gx, gy = cross_section_nodes()
    gw = field.values(gx, gy)
    grid = np.column_stack([gx * radius, gy * radius, gw]).tolist()
    if g.button is not None:
        first_order = weight2d.sensitivity_first_order_button(g.button[0])
    else:
        first_order = 1.0 if g.beta is None else weight2d.sensitivity_first_order(g.beta)
    current = [[float(np.degrees(t)), float(j)] for t, j in field.electrode_current]
    current_map = [] if field.current_map is None else [
        [float(np.degrees(t)), float(z * radius), float(j)] for t, z, j in field.current_map]
    missed = tolerance_missed(field, request.options.tolerance)
    notes = (request_warnings(request, b, mean if profile == "samples" else None, given) + notes
             + signal_warnings(signal, request) + ([missed] if missed else []))
    source = {"conversions": [{"quantity": "length", "from_unit": request.units, "to_unit": "m",
                               "factor": METRES[request.units], "basis": "request",
                               "used_for": "the signal U = 2 R B v_mean S (R in metres)"}]
              + ([] if given is None else given.conversions)}
    if given is not None:
        source["magnetic_field"] = given.description
    progress(1.0, "done")
    return Solved(FlowmeterResult(
        sensitivity=s, sensitivity_first_order=first_order, signal=signal, signal_mv=signal * 1e3,
        units=request.units, grid_units=[request.units, request.units, "1"],
        electrode_current_units=["deg", "1"] if current else [],
        electrode_current_map_units=["deg", request.units, "1"] if current_map else [], probes=probes,
        linearity=linearity(field, list(request.reynolds)),
        ideal_meter_residual=ideal_meter_residual(field, field.integrate(lambda x, y: np.ones_like(x))),
        method=field.method, error_estimate=field.error_estimate, grid=grid, electrode_current=current,
        electrode_current_map=current_map,
        report=Report(status="warning" if notes else "ok",
                      message=f"S = {s:.6f} ({field.method}, estimated error {field.error_estimate:.1e}"
                              + (f", ABOVE the target tolerance {request.options.tolerance:.1e}" if missed else "")
                              + f"); first-order sin(beta)/beta = {first_order:.6f}.",
                      warnings=notes,
                      details={**field.details, "profile": profile, "mean_velocity": mean_velocity,
                               "source": source,
                               "scaling": "S depends only on beta, a/R and L/R: reuse this result for any R "
                                          "with the geometry scaled"})))
