"""Semantic input checks (types, finiteness and lengths are in the schema): every one names the field."""

from __future__ import annotations

import math

from plantsolve.schemas.rigidity import RigidityRequest
from plantsolve.solvers.base import FieldError, InputRejected
from plantsolve.solvers.rigidity.catalogue import lookup
from plantsolve.solvers.rigidity.verdicts import names_lines

MAX_ERRORS = 50
NEEDS_AXIS = {"hinge", "slider", "cylindrical"}


def check_input(request: RigidityRequest) -> None:
    """Bodies and joints or parts (not both, not neither); unique ids; joints between two different,
    existing bodies; axes present and non-zero where the joint type needs one; one shape per body,
    mesh indices in range; a docking part from the catalogue."""
    errors: list[FieldError] = []
    if request.parts and (request.bodies or request.joints):
        errors.append(FieldError(("parts",), "give bodies and joints, or parts, not both"))
    if not request.parts and not request.bodies:
        errors.append(FieldError(("bodies",), "no bodies and no parts: nothing to analyse"))
    seen: dict[str, tuple] = {}
    for field in ("bodies", "parts"):
        for i, item in enumerate(getattr(request, field)):
            if item.id in seen:
                errors.append(FieldError((field, i, "id"), f"id {item.id!r} repeats {'/'.join(map(str, seen[item.id]))}"))
            seen.setdefault(item.id, (field, i))
    for i, body in enumerate(request.bodies):
        shape = body.shape
        if shape is None:
            continue
        if (shape.box is None) == (shape.mesh is None):
            errors.append(FieldError(("bodies", i, "shape"), "give exactly one of box or mesh"))
        elif shape.box is not None and not 1e-6 < math.hypot(*shape.box.rotation) < math.inf:
            errors.append(FieldError(("bodies", i, "shape", "box", "rotation"), "a zero quaternion is no rotation"))
        elif shape.mesh is not None:
            n = len(shape.mesh.vertices)
            for k, face in enumerate(shape.mesh.faces):
                if max(face) >= n:
                    errors.append(FieldError(("bodies", i, "shape", "mesh", "faces", k),
                                             f"vertex index {max(face)} is out of range ({n} vertices)"))
                    break
    body_ids = {b.id for b in request.bodies}
    joint_ids: dict[str, int] = {}
    for i, joint in enumerate(request.joints):
        if joint.id in joint_ids:
            errors.append(FieldError(("joints", i, "id"), f"joint id {joint.id!r} repeats joint {joint_ids[joint.id]}"))
        joint_ids.setdefault(joint.id, i)
        for k, b in enumerate(joint.bodies):
            if b not in body_ids:
                errors.append(FieldError(("joints", i, "bodies", k), f"joint {joint.id!r}: no body {b!r}"))
        if joint.bodies[0] == joint.bodies[1]:
            errors.append(FieldError(("joints", i, "bodies"), f"joint {joint.id!r} joins body {joint.bodies[0]!r} to itself"))
        if joint.type in NEEDS_AXIS:
            if joint.axis is None:
                errors.append(FieldError(("joints", i, "axis"), f"a {joint.type} joint needs an axis"))
            elif max(abs(c) for c in joint.axis) < 1e-12:
                errors.append(FieldError(("joints", i, "axis"), f"joint {joint.id!r}: the axis is zero (every component below 1e-12)"))
        if len(errors) >= MAX_ERRORS:
            break
    for i, part in enumerate(request.parts):
        m = part.rotation
        gram = [[sum(m[3 * r + k] * m[3 * c + k] for k in range(3)) for c in range(3)] for r in range(3)]
        err = max(abs(gram[r][c] - (r == c)) for r in range(3) for c in range(3))
        if err > 1e-3:
            errors.append(FieldError(("parts", i, "rotation"), f"part {part.id!r}: the matrix is not a rotation "
                                     f"(rows not orthonormal within 1e-3; off by {err:.3g})"))
        if len(errors) >= MAX_ERRORS:
            break
    dock = request.options.dock
    if dock is not None:
        if not request.parts:
            errors.append(FieldError(("options", "dock"), "docking needs a parts model"))
        elif lookup(dock.part) is None:
            errors.append(FieldError(("options", "dock", "part"), f"part {dock.part!r} is not in the catalogue"))
    missing = (request.source or {}).get("missing_submodels")
    if missing is not None and not names_lines(missing):
        errors.append(FieldError(("source", "missing_submodels"), "must map each sub-model the file places but does "
                                 "not hold to the lines placing it, as the LDraw reader writes it "
                                 "(e.g. {\"upper.ldr\": [3]}); got " + type(missing).__name__ + " " +
                                 repr(missing)[:80]))
    if errors:
        raise InputRejected(errors[:MAX_ERRORS])
