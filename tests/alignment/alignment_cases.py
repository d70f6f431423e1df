"""Small hand-made pipe systems with known answers."""

import numpy as np

from schemas.alignment import AlignmentRequest


def port(p, d):
    return {"position": [float(v) for v in p], "direction": [float(v) for v in d]}


def request(comps, conns, **options):
    return AlignmentRequest.model_validate({"components": comps, "connections": conns, "options": options})


def pipe(cid, a, b, fixed=False, radius=50.0):
    a, b = np.asarray(a, float), np.asarray(b, float)
    u = (b - a) / np.linalg.norm(b - a)
    return {"id": cid, "kind": "pipe", "radius": radius, "fixed": fixed, "ports": [port(a, -u), port(b, u)]}


def elbow(cid, corner, d0, d1, arm=150.0, fixed=False, rot=None, shift=(0, 0, 0)):
    """90-degree elbow with ports corner + arm*d0 and corner + arm*d1, optionally moved rigidly."""
    from scipy.spatial.transform import Rotation

    corner = np.asarray(corner, float)
    R = Rotation.from_rotvec(rot) if rot is not None else Rotation.identity()
    ports = []
    for d in (d0, d1):
        d = np.asarray(d, float)
        ports.append(port(R.apply(arm * d) + corner + shift, R.apply(d)))
    return {"id": cid, "kind": "fitting", "type": "elbow", "fixed": fixed, "ports": ports}


def conn(a, i, b, j):
    return {"from": [a, i], "to": [b, j]}
