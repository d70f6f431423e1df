"""Small hand-made pipe systems with known answers."""

import numpy as np

from plantsolve.schemas.alignment import AlignmentRequest


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


def route(points, radius=50.0, bend_radius=None, perturb=(0.0, 0.0, 0.0, 0.0), seed=0, fixed_ends=(True, False),
          end_flanges=True, scale=1.0):
    """A single run through ``points``: straight pipes joined by elbows of whatever angle the corners make
    (arm = bend radius x tan(angle / 2)), optionally a fixed flange at either end. ``perturb`` =
    (pipe mm, pipe deg, fitting mm, fitting deg) of scan-like noise, applied as rigid motions (pipes
    also get independent end noise along the axis). Returns (components, connections)."""
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(seed)
    pts = np.asarray(points, float) * scale
    R = (1.5 * 2 * radius if bend_radius is None else bend_radius) * scale
    comps, conns = [], []
    prev = None  # (component id, port index) that the next component joins

    def rigid(ports, mm, deg):
        if mm == 0 and deg == 0:
            return ports
        rot = Rotation.from_rotvec(rng.normal(size=3) * np.radians(deg) / np.sqrt(3))
        c = np.mean([p[0] for p in ports], axis=0)
        t = rng.normal(size=3) * mm / np.sqrt(3)
        return [(rot.apply(p - c) + c + t, rot.apply(d)) for p, d in ports]

    def add(cid, kind, ports, ftype=None, fixed=False):
        nonlocal prev
        if not fixed:
            ports = rigid(ports, *(perturb[:2] if kind == "pipe" else perturb[2:]))
        c = {"id": cid, "kind": kind, "radius": radius * scale, "fixed": fixed,
             "ports": [port(p, d) for p, d in ports]}
        if kind == "fitting":
            c["type"] = ftype
        comps.append(c)
        if prev is not None:
            conns.append(conn(prev[0], prev[1], cid, 0))
        prev = (cid, len(ports) - 1)

    u = [(pts[i + 1] - pts[i]) / np.linalg.norm(pts[i + 1] - pts[i]) for i in range(len(pts) - 1)]
    start = pts[0]
    flange_len = 100.0 * scale
    if end_flanges:
        add("F-start", "fitting", [(start - flange_len * u[0], -u[0]), (start, u[0])], "flange", fixed=fixed_ends[0])
    for i in range(len(u)):
        if i + 1 < len(u):
            ang = np.arccos(np.clip(u[i] @ u[i + 1], -1, 1))
            arm = R * np.tan(ang / 2)
            end = pts[i + 1] - arm * u[i]
        else:
            end = pts[-1]
        add(f"P-{i}", "pipe", [(start, -u[i]), (end, u[i])])
        if i + 1 < len(u):
            add(f"E-{i}", "fitting", [(end, -u[i]), (pts[i + 1] + arm * u[i + 1], u[i + 1])], "elbow")
            start = pts[i + 1] + arm * u[i + 1]
    if end_flanges:
        add("F-end", "fitting", [(pts[-1], -u[-1]), (pts[-1] + flange_len * u[-1], u[-1])], "flange", fixed=fixed_ends[1])
    return comps, conns


SCAN_NOISE = (2.0, 0.3, 6.0, 1.5)  # pipes mm, deg; fittings mm, deg


def straight_run_between_tie_ins():
    # symmetric: the 10 mm offset is spread evenly over the run's two end connections, an exact tie
    comps, conns = route([[0, 0, 0], [6000, 0, 0]], perturb=SCAN_NOISE, seed=3, fixed_ends=(True, True))
    for p in comps[-1]["ports"]:
        p["position"][1] += 10.0
    return request(comps, conns, method="direct", max_iterations=200)


def conflicting_tie_ins_and_a_free_branch():
    e1 = elbow("E1", [0, 0, 0], [0, -1, 0], [1, 0, 0], fixed=True)
    e2 = elbow("E2", [2000, 5.0, 0], [-1, 0, 0], [0, 1, 0], fixed=True)
    comps = [e1, e2, pipe("P", [151.0, 0.8, -0.5], [1849.0, 3.0, 0.7]), pipe("Q", [0, -150, 0], [0, -1150, 0]),
             elbow("E3", [0, -1300, 0], [0, 1, 0], [1, 0, 0], shift=(1.0, -2.0, 0.5), rot=[0, 0, 0.01]),
             pipe("R", [150, -1300, 0], [1150, -1300, 0])]
    conns = [conn("E1", 1, "P", 0), conn("P", 1, "E2", 0), conn("E1", 0, "Q", 0), conn("Q", 1, "E3", 0),
             conn("E3", 1, "R", 0)]
    return request(comps, conns, method="direct")


def loop_grid_with_a_turned_tie_in():
    # a 3 x 3 loop grid whose second tie-in's port directions are turned 3 deg about z (its ports stay in place):
    # its first round stops on the conflict's plateau, where the two factorisations' poses lie far apart
    from scipy.spatial.transform import Rotation

    from plantsolve.solvers.alignment.synthetic import grid_network

    req = grid_network(3, 3, seed=2, tie_ins=((0, 0), (2, 2)), origin=(1.0e6, 2.0e5, 1.0e4),
                       options={"method": "direct", "max_cuts": 5})
    comps = [c.model_copy(deep=True) for c in req.components]
    moved = [c for c in comps if c.fixed][-1]
    for p in moved.ports:
        p.direction = Rotation.from_rotvec([0.0, 0.0, np.radians(3.0)]).apply(p.direction).tolist()
    return req.model_copy(update={"components": comps})


def random_kkt_blocks(seed: int = 3):
    """A cost of ten random positive-definite 3 x 3 blocks and 12 random constraints on its 30 variables, as the
    KKT tests build them: ``(H, A, rng)``, the generator left where the two were drawn for what a test draws next."""
    import scipy.sparse as sp

    rng = np.random.default_rng(seed)
    blocks = []
    for _ in range(10):
        B = rng.normal(size=(3, 3))
        blocks.append(B @ B.T + 0.5 * np.eye(3))
    return sp.block_diag(blocks, format="csc"), sp.csr_matrix(rng.normal(size=(12, 30))), rng
