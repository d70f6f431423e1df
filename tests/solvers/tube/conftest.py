import numpy as np
import pytest

from plantsolve.schemas.tube import TubeRequest
from plantsolve.solvers.tube.synthetic import make_model, surface_samples

SHAPES = {
    "straight": [[80, 0, 0, 0]],
    "bend90": [[40, 0, 90, 12], [40, 0, 0, 0]],
    "s_bend": [[40, 0, 60, 12], [20, 180, 60, 12], [30, 0, 0, 0]],
    "u_bend": [[40, 0, 180, 12], [30, 0, 0, 0]],
    "bend200": [[40, 0, 200, 12], [45, 0, 0, 0]],
    "back_to_back": [[40, 0, 90, 12], [0, 90, 90, 12], [35, 0, 0, 0]],
    "bend3": [[60, 0, 3, 12], [50, 0, 0, 0]],
    "three_bends": [[30, 0, 45, 10], [15, 70, 90, 14], [20, -120, 30, 12], [25, 0, 0, 0]],
}


def scan(rows, n=5000, seed=0, view=None, noise=0.0, outliers=0.0, pipe_radius=4.0):
    rng = np.random.default_rng(seed)
    m = make_model(rows, pipe_radius)
    return m, surface_samples(m, n, rng, view=view, noise=noise, outlier_fraction=outliers)


def request(pts, **opts):
    return TubeRequest(points=pts.tolist(), options=opts)


def lra_array(result):
    return np.array([[r.length, r.rotation, r.angle, r.bend_radius] for r in result.lra])


def same_tube(result, rows, tol_len=0.15, tol_ang=0.1, tol_rad=0.01):
    """Compare a result with LRA rows, allowing the reversed walking direction."""
    from plantsolve.solvers.tube.model import reverse_model
    from plantsolve.solvers.tube.lra import model_rows

    truth = make_model(rows, 4.0)
    got = lra_array(result)
    cands = []
    for m in (truth, reverse_model(truth)):
        t = np.array([[r.length, r.rotation, r.angle, r.bend_radius] for r in model_rows(m)])
        cands.append(t)
    errs = []
    for t in cands:
        if t.shape != got.shape:
            errs.append(f"shape {got.shape} != {t.shape}")
            continue
        d = got - t
        d[:, 1] = (d[:, 1] + 180) % 360 - 180
        bad = []
        if np.abs(d[:, 0]).max() > tol_len:
            bad.append(f"length {d[:, 0]}")
        if np.abs(d[:, 1:3]).max() > tol_ang:
            bad.append(f"angles {d[:, 1:3]}")
        rel = np.abs(d[:-1, 3]) / t[:-1, 3] if len(t) > 1 else np.zeros(0)
        if len(rel) and rel.max() > tol_rad:
            bad.append(f"radius {d[:, 3]}")
        if not bad:
            return
        errs.append("; ".join(bad))
    raise AssertionError(f"{got} vs truth: {errs}")


@pytest.fixture
def s_bend_scan():
    return scan(SHAPES["s_bend"], n=5000, seed=3, view=[0.3, 0.2, -1.0], noise=0.05, outliers=0.005)


@pytest.fixture
def tk():
    """Helpers for the tests (conftest cannot be imported under --import-mode=importlib)."""
    from types import SimpleNamespace

    return SimpleNamespace(SHAPES=SHAPES, scan=scan, request=request, same_tube=same_tube, lra_array=lra_array)


@pytest.fixture(scope="module")
def tk_module():
    """The same helpers for module-scoped fixtures (a solve shared by several tests)."""
    from types import SimpleNamespace

    return SimpleNamespace(SHAPES=SHAPES, scan=scan, request=request, same_tube=same_tube, lra_array=lra_array)
