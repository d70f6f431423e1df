"""A 180° return bend written ANGLE 180 in degrees whose CENTRE-POINT lies a few mm off its chord: its points then
agree with E3D's hundredths reading (1.8°) as well, and read so it lost both connections. Its BEND-RADIUS decides:
the chord is 2·R for the return bend, while a 1.8° elbow's arms are R·tan(0.9°)."""

import numpy as np
import pytest

from plantsolve.solvers.alignment.pcf import interpret_pcf
from plantsolve.solvers.alignment.solve import solve
from plantsolve.solvers.alignment.upload import parse_upload
from plantsolve.solvers.base import StoredInput
from tests.support.pcf_lines import elbow_line

R = 228.6  # mm, a 6" long-radius return bend


def _f(p) -> str:
    return " ".join(f"{v:.4f}" for v in p)


def _return_bend(off: float, radius_record: str | None = f"{R:.4f}") -> str:
    """Pipe along +x, a return bend of radius R (CENTRE-POINT ``off`` mm beyond the chord's middle, along +x), pipe
    back along -x."""
    a = np.array([1000.0, 0, 0])
    b = a + [0, 2 * R, 0]
    c = a + [off, R, 0]
    radius = f"    BEND-RADIUS {radius_record}\n" if radius_record else ""
    return ("ISOGEN-FILES ISOGEN.FLS\nUNITS-BORE MM\nUNITS-CO-ORDS MM\nPIPELINE-REFERENCE TEST-1\n"
            f"PIPE\n    END-POINT {_f([0, 0, 0])} 100.0000\n    END-POINT {_f(a)} 100.0000\n"
            f"BEND\n    END-POINT {_f(a)} 100.0000\n    END-POINT {_f(b)} 100.0000\n    CENTRE-POINT {_f(c)}\n"
            f"    ANGLE 180\n{radius}"
            f"PIPE\n    END-POINT {_f(b)} 100.0000\n    END-POINT {_f(b - [1000, 0, 0])} 100.0000\n")


@pytest.mark.parametrize("off", [3.0, 1.0, 0.0])
def test_a_return_bend_whose_chord_is_twice_its_bend_radius_stays_180_degrees(off):
    request = parse_upload(StoredInput.from_bytes("line.pcf", _return_bend(off).encode()), {})
    # before, a CENTRE-POINT 3 mm off the chord read ANGLE 180 as 1.8°: no connection, a records contradiction
    assert len(request.connections) == 2
    bend = next(c for c in request.components if c.kind == "fitting")
    d0, d1 = (np.asarray(p.direction) / np.linalg.norm(p.direction) for p in bend.ports)
    assert d0 == pytest.approx([-1.0, 0.0, 0.0], abs=1e-9) and d1 == pytest.approx([-1.0, 0.0, 0.0], abs=1e-9)
    report = solve(request).result.report
    assert not {"pcf_unconnected_items", "pcf_near_miss", "pcf_records_contradict_points"} & {
        w.code for w in report.warnings}


def _elbow(theta: float, radius: float, radius_record: float) -> str:
    """Pipe, elbow of ``theta`` degrees on ``radius`` recorded ANGLE 180 and BEND-RADIUS ``radius_record``, pipe."""
    return elbow_line(theta, "180", radius, radius_record)


def test_e3ds_hundredths_still_read_when_the_bend_radius_fits_the_small_turn():
    request = parse_upload(StoredInput.from_bytes("line.pcf", _elbow(1.8, R, R).encode()), {})
    assert len(request.connections) == 2
    elbow = next(c for c in request.components if c.kind == "fitting")
    d0, d1 = (np.asarray(p.direction) / np.linalg.norm(p.direction) for p in elbow.ports)
    assert 180.0 - np.degrees(np.arccos(np.clip(d0 @ d1, -1, 1))) == pytest.approx(1.8, abs=1e-3)


def test_a_bend_radius_that_fits_neither_reading_keeps_the_degrees_and_is_named_with_the_chords_radius():
    # points of a 1.8° elbow on R 228.6 whose BEND-RADIUS says 1000: the hundredths are not taken on the points'
    # word alone, so it is the return bend ANGLE 180 says, and its BEND-RADIUS is named against half its chord
    # (R·sin(0.9°)); nothing joins its sideways ports, and that is said too
    notes = {code: details for code, _, details, level in interpret_pcf(_elbow(1.8, R, 1000.0), {}).notes
             if level == "warning"}
    (found,) = notes["pcf_records_contradict_points"]["records"]
    assert (found["record"], found["record_line"], found["read_as"]) == ("BEND-RADIUS", 13, 1000.0)
    assert found["from_points"] == pytest.approx(R * np.sin(np.radians(0.9)), abs=1e-3)
    request = parse_upload(StoredInput.from_bytes("line.pcf", _elbow(1.8, R, 1000.0).encode()), {})
    assert "pcf_unconnected_items" in {w.code for w in solve(request).result.report.warnings}


@pytest.mark.parametrize("off", [2.0, 3.0])
def test_without_a_bend_radius_a_nudged_return_bend_stays_180_degrees_by_its_bore(off):
    """No BEND-RADIUS: read as 1.8°, the points would give a radius of 14.5 m on a 100 mm bore (a 6" bend nudged 2 mm
    off its chord), which no bend of that pipe has; a small turn is read only where the radius fits a bend."""
    text = _return_bend(off, radius_record=None)
    request = parse_upload(StoredInput.from_bytes("line.pcf", text.encode()), {})
    assert len(request.connections) == 2
    assert not {"pcf_unconnected_items", "pcf_near_miss"} & {w.code for w in solve(request).result.report.warnings}


def test_without_a_bend_radius_e3ds_hundredths_are_read_on_a_bend_of_a_few_bores():
    request = parse_upload(StoredInput.from_bytes("line.pcf", elbow_line(1.8, "180", R).replace(
        f"    BEND-RADIUS {R:.4f}\n", "").encode()), {})
    elbow = next(c for c in request.components if c.kind == "fitting")
    d0, d1 = (np.asarray(p.direction) / np.linalg.norm(p.direction) for p in elbow.ports)
    assert 180.0 - np.degrees(np.arccos(np.clip(d0 @ d1, -1, 1))) == pytest.approx(1.8, abs=1e-3)
