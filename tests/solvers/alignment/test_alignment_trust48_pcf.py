"""An elbow's ANGLE and BEND-RADIUS records against its points: E3D's hundredths of a degree (ANGLE 180 for a
1.8° bend) read as a 180° return bend lost both its connections; a record that contradicts the END-POINT and
CENTRE-POINT lines is named, with the line and both values; the exports' own files say nothing."""

from pathlib import Path

import numpy as np
import pytest

from plantsolve.solvers.alignment.pcf import interpret_pcf
from plantsolve.solvers.alignment.solve import solve
from plantsolve.solvers.alignment.upload import parse_upload
from plantsolve.solvers.base import StoredInput
from tests.support.pcf_lines import elbow_line as _line

DATA = Path(__file__).parent / "data"
PLANT3D = (DATA / "plant3d_cw_line.pcf").read_text()


def _warnings(text: str) -> dict:
    return {code: (message, details) for code, message, details, level in interpret_pcf(text, {}).notes
            if level == "warning"}


@pytest.mark.parametrize("theta, record", [(1.8, "180"), (2.5, "250"), (1.8, "1.8"), (45.0, "4500"), (45.0, "45")])
def test_an_elbows_angle_record_reads_in_the_unit_its_points_agree_with(theta, record):
    text = _line(theta, record)
    request = parse_upload(StoredInput.from_bytes("line.pcf", text.encode()), {})
    # the elbow joins both pipes; before, ANGLE 180 (E3D's 1.8°) made it a return bend whose connections were lost
    assert len(request.connections) == 2
    report = solve(request).result.report
    assert not {"pcf_unconnected_items", "pcf_near_miss", "pcf_records_contradict_points"} & {
        w.code for w in report.warnings}
    elbow = next(c for c in request.components if c.kind == "fitting")
    d0, d1 = (np.asarray(p.direction) / np.linalg.norm(p.direction) for p in elbow.ports)
    assert 180.0 - np.degrees(np.arccos(np.clip(d0 @ d1, -1, 1))) == pytest.approx(theta, abs=1e-3)


def test_an_angle_record_its_points_contradict_is_named_with_both_values():
    text = _line(45.0, "9000")
    message, details = _warnings(text)["pcf_records_contradict_points"]
    (found,) = details["records"]
    assert (found["record"], found["record_line"], found["line"]) == ("ANGLE", 12, 8)
    assert found["read_as"] == 90.0 and found["from_points"] == pytest.approx(45.0, abs=1e-3)
    assert "line 12: ANGLE 9000" in message and "45 deg" in message


def test_a_bend_radius_record_its_points_contradict_is_named():
    text = PLANT3D.replace("BEND-RADIUS 228.6000", "BEND-RADIUS 152.4000", 1)
    message, details = _warnings(text)["pcf_records_contradict_points"]
    (found,) = details["records"]
    line = text.splitlines().index("    BEND-RADIUS 152.4000") + 1
    assert (found["record"], found["record_line"], found["read_as"]) == ("BEND-RADIUS", line, 152.4)
    assert found["from_points"] == pytest.approx(228.6, abs=1e-3) and found["unit"] == "mm"
    assert f"line {line}: BEND-RADIUS 152.4000" in message


@pytest.mark.parametrize("path", [*sorted(DATA.glob("*.pcf")), Path(__file__).parents[3] / "examples" / "alignment"
                                  / "ladder.pcf"], ids=lambda p: p.name)
def test_exports_and_fixtures_raise_no_record_contradiction(path):
    assert "pcf_records_contradict_points" not in _warnings(path.read_bytes().decode("utf-8", errors="replace"))
