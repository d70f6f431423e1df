"""A text scan in micrometres is read wherever its unit is stated — a comment, the columns' names or their line of
units, options.file_units — by the one table of length units (``length_units.SIZES``), as a PLY comment's was: it
was refused (the upload's table had no micrometres), or its columns ``x [µm]`` were taken for no x, y, z at all."""

import numpy as np
import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.tube.scan import TubeScan
from plantsolve.solvers.tube.synthetic import make_model, surface_samples
from plantsolve.solvers.tube.upload import parse_upload

PTS = surface_samples(make_model([(400, 0, 90, 100), (300, 0, 0, 0)], 20.0), 300, np.random.default_rng(0))


def _text(head: str, pts, sep: str = " ") -> bytes:
    return (head + "".join(sep.join(f"{v:.3f}" for v in p) + "\n" for p in pts)).encode()


@pytest.mark.parametrize(("head", "sep"), [("# units: um\n", " "), ("# Units = µm\n", " "), ("// unit: microns\n", " "),
                                           ("x [µm] y [µm] z [µm]\n", " "), ("x_um,y_um,z_um\n", ","),
                                           ("X (μm),Y (μm),Z (μm)\n", ","), ("x,y,z\nµm,µm,µm\n", ",")])
def test_a_text_scan_stating_micrometres_is_read_in_them(head, sep):
    req = parse_upload(StoredInput.from_bytes("scan.xyz", _text(head, PTS * 1000, sep)), None)
    assert (req.source.units.basis, req.source.units.file_unit, req.source.units.factor) == ("header", "um", 1e-3)
    assert np.allclose(TubeScan(req).points, PTS, atol=1e-3)


@pytest.mark.parametrize("word", ["um", "µm", "Microns", "micrometres"])
def test_options_file_units_in_micrometres_reads_a_scan_stating_none(word):
    req = parse_upload(StoredInput.from_bytes("scan.xyz", _text("", PTS * 1000)), {"file_units": word})
    assert (req.source.units.basis, req.source.units.file_unit) == ("options.file_units", "um")
    assert req.options.file_units == "um"  # the stored request says what the user said, as for any other unit
    assert np.allclose(TubeScan(req).points, PTS, atol=1e-3)


def test_a_unit_no_length_is_still_refused_naming_the_option():
    with pytest.raises(InputRejected) as refused:
        parse_upload(StoredInput.from_bytes("scan.xyz", _text("", PTS)), {"file_units": "furlong"})
    assert refused.value.errors[0].loc == ("options", "file_units")
