"""Blank-separated headers read as they were before a bracketed word became a column's unit: a bracketed word after
a coordinate's name is its unit only when it spells a length unit (``x (east)`` and ``z []`` are words of their
own), a unit after the last coordinate alone (``X Y Z [mm]``) is the three's, and ``E N H`` names easting,
northing and height (``E (m) N (m) H (m)`` was refused as naming no x, y, z)."""

import numpy as np
import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.tube.scan import TubeScan
from plantsolve.solvers.tube.synthetic import make_model, surface_samples
from plantsolve.solvers.tube.upload import parse_upload

PTS = surface_samples(make_model([(400, 0, 90, 100), (300, 0, 0, 0)], 20.0), 300, np.random.default_rng(0))
SIZE = {"mm": 1.0, "m": 1000.0, "in": 25.4}


def _read(head: str, unit: str, extra: int = 0):
    rows = "".join(" ".join(f"{v:.7f}" for v in [*(p / SIZE[unit]), *[7.0 + k for k in range(extra)]]) + "\n"
                   for p in PTS)
    req = parse_upload(StoredInput.from_bytes("scan.xyz", (head + "\n" + rows).encode()), None)
    return req, TubeScan(req).points


@pytest.mark.parametrize(("head", "unit", "extra"), [
    ("X Y Z [in]", "in", 0), ("x y z (in)", "in", 0), ("x y z [in] nx ny nz", "in", 3), ("E (m) N (m) H (m)", "m", 0),
    ("E N H [m]", "m", 0), ("x [in] y [in] z [in] intensity [%]", "in", 1), ("x [in] y [in] z [in] i [dB]", "in", 1)])
def test_a_unit_the_header_states_is_read(head, unit, extra):
    req, points = _read(head, unit, extra)
    assert (req.source.units.basis, req.source.units.file_unit) == ("header", unit)
    assert np.allclose(points, PTS, atol=1e-4)


@pytest.mark.parametrize(("head", "extra"), [("x (east) y (north) z (up)", 0), ("x [] y [] z []", 0),
                                             ("x y z i (0-255)", 1)])
def test_a_header_stating_no_unit_reads_the_request_unit(head, extra):
    req, points = _read(head, "mm", extra)
    assert req.source.units.basis == "request" and np.allclose(points, PTS, atol=1e-5)


def test_a_first_column_named_n_is_no_northing():
    rows = "".join(f"{i} " + " ".join(f"{v:.7f}" for v in p) + "\n" for i, p in enumerate(PTS))
    req = parse_upload(StoredInput.from_bytes("scan.xyz", ("n x y z\n" + rows).encode()), None)
    assert np.allclose(TubeScan(req).points, PTS, atol=1e-5)


@pytest.mark.parametrize("head", ["x [in] y z", "x [in] y [mm] z [mm]"])
def test_units_stated_for_some_coordinates_but_not_after_the_last_are_refused(head):
    with pytest.raises(InputRejected, match="line 1"):
        _read(head, "in")
