"""Semantic input checks (types, finiteness and bounds are in the schema)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.interpolate import RegularGridInterpolator
from scipy.spatial import ConvexHull, QhullError

from plantsolve.schemas.flowmeter import FlowmeterRequest
from plantsolve.solvers.base import FieldError, InputRejected
from plantsolve.solvers.flowmeter.field import FILE, request_field
from plantsolve.solvers.flowmeter.integral_equation import feasible
from plantsolve.solvers.flowmeter.integral_equation_button import feasible as feasible_button
from plantsolve.solvers.flowmeter.plausibility import METRES
from plantsolve.solvers.flowmeter.profiles import disc_quadrature, sampled


@dataclass(frozen=True)
class MeterShape:
    """The meter in units of the pipe radius (the only lengths S depends on)."""

    beta: float | None  # electrode half-angle in radians; None for point and button electrodes
    half_length: float  # a / R (the liner's half-length for full-length electrodes)
    half_liner: float  # L / (2 R)
    full_length: bool
    button: tuple[float, float] | None = None  # (r_e / R, l_e / R) of button electrodes


def meter_shape(request: FlowmeterRequest) -> MeterShape:
    radius = request.pipe.radius
    liner = request.pipe.liner_length if request.pipe.liner_length is not None else 6 * radius
    half_liner = liner / (2 * radius)
    e = request.electrodes
    if e.shape == "point":
        return MeterShape(None, 0.0, half_liner, False)
    if e.shape == "button":
        r_e = (e.radius or 0.0) / radius
        return MeterShape(None, r_e, half_liner, False, (r_e, e.protrusion / radius))
    full = e.half_length is None or e.half_length >= liner / 2 * (1 - 1e-12)
    a = half_liner if full else e.half_length / radius
    return MeterShape(float(np.radians(e.half_angle)), a, half_liner, full)


# hard bounds of the bore (radius) in metres, whatever the unit: outside them no pipe exists
RADIUS_M = (1e-5, 1000.0)
# a mean stated beside samples agrees with theirs within this (rounded as written); otherwise which is meant is not known
SAMPLED_MEAN_AGREEMENT = 0.01


def check_input(request: FlowmeterRequest) -> None:
    """Fast semantic validation; raises :class:`InputRejected` naming each bad field."""
    errors: list[FieldError] = []
    radius = request.pipe.radius
    metres = radius * METRES[request.units]
    if not RADIUS_M[0] <= metres <= RADIUS_M[1]:
        raise InputRejected(FieldError(("pipe", "radius"), (
            f"a radius of {radius:g} {request.units} is {metres:g} m; a pipe's radius lies within "
            f"{RADIUS_M[0] * 1000:g} mm and {RADIUS_M[1]:g} m (is 'units' right?)")))
    liner = request.pipe.liner_length if request.pipe.liner_length is not None else 6 * radius
    e = request.electrodes
    if e.shape == "patch" and e.half_length is not None and e.half_length > liner / 2 * (1 + 1e-12):
        errors.append(FieldError(("electrodes", "half_length"),
                                 f"the electrode half-length {e.half_length:g} exceeds half the liner length "
                                 f"({liner / 2:g}); use null for electrodes along the whole liner"))
    if e.shape == "point" and e.half_length is not None:
        errors.append(FieldError(("electrodes", "half_length"), "point electrodes have no half-length; leave it null"))
    errors += button_errors(request, liner)
    if request.options.method == "integral_equation" and e.shape == "button":
        if e.protrusion > 0:
            errors.append(FieldError(("options", "method"),
                                     "the integral equation lives on the wall: it models flush buttons (protrusion 0); "
                                     "a protruding button takes 'fem' (or 'auto')"))
        elif e.radius is not None and 0.02 * radius <= e.radius <= 0.8 * radius and not feasible_button(
                e.radius / radius, liner / (2 * radius), request.options.tolerance):
            errors.append(FieldError(("options", "method"),
                                     f"a button this small (r_e/R = {e.radius / radius:.3g}) needs more modes than the "
                                     "integral equation's memory budget; use 'fem' or 'auto'"))
    elif request.options.method == "integral_equation":
        if e.shape != "patch" or e.half_length is None or e.half_length >= liner / 2:
            errors.append(FieldError(("options", "method"),
                                     "'integral_equation' models patches shorter than the liner; full-length and point "
                                     "electrodes are solved exactly ('auto')"))
        elif not feasible(float(np.radians(e.half_angle)), e.half_length / radius, liner / (2 * radius)):
            errors.append(FieldError(("options", "method"),
                                     f"electrodes this short for their width (a/R = {e.half_length / radius:.3g}, "
                                     f"beta = {e.half_angle:g} deg) need more modes than the integral equation's "
                                     "memory budget; use 'fem' or 'auto'"))
    if request.options.method == "fem" and e.shape == "point":
        errors.append(FieldError(("options", "method"), "'fem' models patches and buttons; point electrodes are solved exactly"))
    if request.options.method == "first_order" and e.shape == "button":
        errors.append(FieldError(("options", "method"),
                                 "'first_order' is the seed's iterate for patches; buttons take 'auto', "
                                 "'integral_equation' (flush) or 'fem'"))
    finite_patch = e.shape == "patch" and e.half_length is not None and e.half_length < liner / 2
    if finite_patch and e.half_length / radius < 0.02:
        errors.append(FieldError(("electrodes", "half_length"),
                                 f"a/R = {e.half_length / radius:.3g} is below 0.02, finer than the finite-element mesh "
                                 "resolves; use point electrodes"))
    if finite_patch and liner / radius < 0.5:
        errors.append(FieldError(("pipe", "liner_length"), f"L/R = {liner / radius:.3g}; at least 0.5 for patch electrodes"))
    if e.shape == "patch" and not liner / radius <= 200:
        errors.append(FieldError(("pipe", "liner_length"),
                                 f"L/R = {liner / radius:g}; at most 200 (the virtual current has decayed long before)"))
    for k, p in enumerate(request.options.probe_points):
        if len(p) not in (2, 3):
            errors.append(FieldError(("options", "probe_points", k), f"a probe is [x, y] or [x, y, z]; got {len(p)} numbers"))
        elif not np.hypot(p[0], p[1]) < radius:
            errors.append(FieldError(("options", "probe_points", k),
                                     f"({p[0]:g}, {p[1]:g}) is not inside the pipe (radius {radius:g})"))
    if request.magnetic_field.type in ("grid", "points") or request.options.magnetic_field_file is not None:
        errors += grid_errors(request, liner)
    v = request.velocity
    if v.type == "samples":
        errors += sample_errors(request)
    elif v.points is not None or v.values is not None:
        errors.append(FieldError(("velocity", "points"), f"points and values belong to type 'samples', not {v.type!r}"))
    if "n" in v.model_fields_set and v.type != "power_law":
        # {"mean": 2, "n": 7} without a type is the uniform profile: the exponent would go unused without a word
        errors.append(FieldError(("velocity", "n"), f"the exponent n belongs to type 'power_law', not {v.type!r}: "
                                 "give \"type\": \"power_law\", or leave n out"))
    if errors:
        raise InputRejected(errors)


def button_errors(request: FlowmeterRequest, liner: float) -> list[FieldError]:
    """A button needs a radius that the wall holds without the two electrodes meeting, and a
    protrusion that keeps the tips apart; patches and points take neither field."""
    e = request.electrodes
    radius = request.pipe.radius
    if e.shape != "button":
        out = []
        if e.radius is not None:
            out.append(FieldError(("electrodes", "radius"), f"'radius' belongs to button electrodes, not {e.shape!r}"))
        if e.protrusion != 0:
            out.append(FieldError(("electrodes", "protrusion"), f"'protrusion' belongs to button electrodes, not {e.shape!r}"))
        return out + half_angle_errors(request)
    errors = half_angle_errors(request)
    if e.radius is None:
        return errors + [FieldError(("electrodes", "radius"), "a button electrode needs its radius r_e")]
    if e.half_length is not None:
        errors.append(FieldError(("electrodes", "half_length"), "button electrodes have no half-length; leave it null"))
    if not 0.02 * radius <= e.radius <= 0.8 * radius:
        errors.append(FieldError(("electrodes", "radius"),
                                 f"r_e/R = {e.radius / radius:.3g}; a button needs 0.02 <= r_e/R <= 0.8 (smaller is a point "
                                 "electrode; larger wraps round the pipe towards the other electrode)"))
    elif e.radius > liner / 2:
        errors.append(FieldError(("electrodes", "radius"),
                                 f"r_e = {e.radius:g} exceeds half the liner length ({liner / 2:g}): the button does not fit"))
    if not e.protrusion <= 0.9 * radius:
        errors.append(FieldError(("electrodes", "protrusion"),
                                 f"l_e/R = {e.protrusion / radius:.3g}; at most 0.9 (the two tips would meet at the "
                                 "pipe's mid-plane)"))
    if liner / radius < 0.5:
        errors.append(FieldError(("pipe", "liner_length"), f"L/R = {liner / radius:.3g}; at least 0.5 for button electrodes"))
    if not liner / radius <= 200:
        errors.append(FieldError(("pipe", "liner_length"),
                                 f"L/R = {liner / radius:g}; at most 200 (the virtual current has decayed long before)"))
    return errors


def half_angle_errors(request: FlowmeterRequest) -> list[FieldError]:
    """A half-angle given with point or button electrodes would go unused: the user who wrote it may have meant
    patches, and the answer would not show that it was ignored."""
    e = request.electrodes
    if e.shape == "patch" or "half_angle" not in e.model_fields_set:
        return []
    size = "a button's size is its 'radius'" if e.shape == "button" else "a point electrode has no size"
    return [FieldError(("electrodes", "half_angle"),
                       f"'half_angle' belongs to patch electrodes, not {e.shape!r} ({size}): give "
                       "\"shape\": \"patch\", or leave half_angle out")]


def grid_errors(request: FlowmeterRequest, liner: float) -> list[FieldError]:
    """A field on a grid (flat, points or a file): a grid the solver can read, covering the liner section, with a
    B_y at the centre to normalise by."""
    f = request.magnetic_field
    radius = request.pipe.radius
    if request.electrodes.shape == "point":
        loc = ("options", "magnetic_field_file") if request.options.magnetic_field_file is not None else ("magnetic_field", "type")
        return [FieldError(loc, "a field on a grid needs the 3-D virtual current, computed for patches and buttons only; "
                                "point electrodes take a uniform field")]
    if f.type == "grid" and request.options.magnetic_field_file is None:
        errors = flat_grid_errors(request)
        if errors:
            return errors
    try:
        field = request_field(request)
    except InputRejected as exc:
        return list(exc.errors)
    errors = []
    for name, reach in (("x", radius), ("y", radius), ("z", liner / 2)):
        axis = getattr(field, name)
        if axis[0] > -reach * (1 - 1e-9) or axis[-1] < reach * (1 - 1e-9):
            loc = ("magnetic_field", name) if field.loc == ("magnetic_field",) else field.loc
            if field.length_unit is None:
                hint = (f"; the file's header states no length unit, so its coordinates are read in the request's "
                        f"units ('{request.units}')")
            elif field.loc == FILE:
                hint = f"; the file's header states its coordinates in {field.length_unit}"
            else:
                hint = ""
            errors.append(FieldError(loc, f"the grid spans {name} = {axis[0]:g}..{axis[-1]:g} and does not cover the pipe "
                                          f"(-{reach:g}..{reach:g}{' along the liner' if name == 'z' else ''}, "
                                          f"{request.units}){hint}"))
    if errors:
        return errors
    centre = RegularGridInterpolator((field.x, field.y, field.z), field.by)([[0.0, 0.0, 0.0]])[0]
    if not abs(centre) > 1e-12 * max(float(np.max(np.abs(field.by))), 1e-300):
        loc = ("magnetic_field", "by") if field.loc == ("magnetic_field",) else field.loc
        errors.append(FieldError(loc, "B_y at the pipe centre is zero; S is normalised by it (B along +y)"))
    return errors


def flat_grid_errors(request: FlowmeterRequest) -> list[FieldError]:
    """The flat grid form: increasing axes and one value per grid point."""
    f = request.magnetic_field
    errors = []
    for name in ("x", "y", "z"):
        if np.any(np.diff(np.asarray(getattr(f, name), dtype=float)) <= 0):
            errors.append(FieldError(("magnetic_field", name), "grid coordinates must increase strictly"))
    count = len(f.x) * len(f.y) * len(f.z)
    for name in ("bx", "by", "bz"):
        values = getattr(f, name)
        if values is not None and len(values) != count:
            errors.append(FieldError(("magnetic_field", name),
                                     f"{len(values)} values for a {len(f.x)} x {len(f.y)} x {len(f.z)} grid ({count} points)"))
    return errors


def _repeated_sample(points: np.ndarray, values: np.ndarray) -> FieldError | None:
    """A point sampled twice with different values (a row copied and edited): the triangulation would keep one of
    them without a word. The same value twice is harmless."""
    _, first, group = np.unique(points, axis=0, return_index=True, return_inverse=True)
    group = group.ravel()
    for k in np.flatnonzero(values != values[first[group]]):
        i = int(first[group[k]])
        return FieldError(("velocity", "points", int(k)),
                          f"the sample point ({points[k, 0]:g}, {points[k, 1]:g}) is also points[{i}], with another value "
                          f"({values[k]:g} against {values[i]:g}): which is meant is not known")
    return None


def sample_errors(request: FlowmeterRequest) -> list[FieldError]:
    v = request.velocity
    radius = request.pipe.radius
    if v.points is None or v.values is None:
        return [FieldError(("velocity", "points" if v.points is None else "values"),
                           "type 'samples' needs points and values")]
    if len(v.points) != len(v.values):
        return [FieldError(("velocity", "values"), f"{len(v.values)} values for {len(v.points)} points")]
    bad = [k for k, p in enumerate(v.points) if len(p) != 2]
    if bad:
        return [FieldError(("velocity", "points", bad[0]), "a sample point is [x, y]")]
    points = np.asarray(v.points, dtype=float) / radius
    outside = np.flatnonzero(np.hypot(points[:, 0], points[:, 1]) > 1 + 1e-9)
    if len(outside):
        return [FieldError(("velocity", "points", int(outside[0])), "the sample point lies outside the pipe")]
    repeated = _repeated_sample(np.asarray(v.points, dtype=float), np.asarray(v.values, dtype=float))
    if repeated:
        return [repeated]
    try:
        hull = ConvexHull(points)
    except (QhullError, ValueError):
        return [FieldError(("velocity", "points"), "the sample points do not span the cross-section (fewer than 3, or on a line)")]
    if hull.volume < 0.5 * np.pi:
        return [FieldError(("velocity", "points"),
                           f"the samples cover {100 * hull.volume / np.pi:.0f} % of the cross-section; at least half is needed")]
    velocity, _ = sampled(points, np.asarray(v.values, dtype=float))
    quadrature = disc_quadrature(radial=24, scale=4.0, max_angular=512)
    flow = velocity(quadrature.x, quadrature.y)
    mean = float(np.sum(flow * quadrature.w) / np.pi)
    if not abs(mean) > 1e-9 * max(float(np.max(np.abs(flow))), 1e-300):
        return [FieldError(("velocity", "values"), "the sampled flow has no mean velocity; S = U / (2 R B v_mean) is undefined")]
    if "mean" in v.model_fields_set and not abs(v.mean - mean) <= SAMPLED_MEAN_AGREEMENT * abs(mean):
        # the samples are the flow, their mean the signal's: a stated mean meant to scale them would be ignored
        return [FieldError(("velocity", "mean"),
                           f"mean {v.mean:g} m/s, but the samples' mean velocity is {mean:.4g} m/s: with type 'samples' "
                           "the samples are the flow (values in m/s); leave mean out, or scale the values")]
    return []
