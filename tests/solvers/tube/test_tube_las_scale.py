"""Scan files a reader refuses, each in one line naming the cause. A LAS file whose scale factor rounds the
coordinates coarser than a tube's radius (0.01 m, laspy's and PDAL's default) is refused naming the scale: the fit
failed on it with 'the samples do not look like a tube surface' (and, at 0.01 ft, gave a 62° bend on a 141 mm CLR
and an inspection FAIL). A damaged E57 is refused without libE57's debug dump, which named the upload's path."""

from __future__ import annotations

import io

import laspy
import numpy as np
import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.tube import synthetic
from plantsolve.solvers.tube.upload import parse_upload

METRES = np.array(synthetic.example()["points"]) / 1000.0  # a 4 mm tube, 1,500 samples, in metres


def las(scale: float) -> bytes:
    header = laspy.LasHeader(point_format=6, version="1.4")
    header.scales, header.offsets = np.full(3, scale), np.zeros(3)
    data = laspy.LasData(header)
    data.x, data.y, data.z = METRES.T
    out = io.BytesIO()
    data.write(out)
    return out.getvalue()


def test_a_las_scale_of_a_centimetre_is_refused_naming_it_and_a_fine_one_read():
    with pytest.raises(InputRejected) as caught:
        parse_upload(StoredInput.from_bytes("scan.las", las(0.01)), None)
    (error,) = caught.value.errors
    assert error.loc == ("file",)
    assert error.msg.startswith("the LAS header's scale factors (0.01, 0.01, 0.01) round every coordinate to 10 mm "
                                "steps: the file's 1,500 points fall on ")
    request = parse_upload(StoredInput.from_bytes("scan.las", las(1e-6)), None)
    assert np.allclose(np.asarray(request.points), METRES * 1000.0, atol=1e-3)


def test_a_damaged_e57_is_refused_in_one_line_without_the_servers_path():
    with pytest.raises(InputRejected) as caught:
        parse_upload(StoredInput.from_bytes("scan.e57", b"ASTM-E57" + bytes(100)), None)
    (error,) = caught.value.errors
    assert error.loc == ("file",)
    assert error.msg == "unreadable E57 file: read() failed (ErrorReadFailed)"
