"""A PCF whose UNITS-BORE names no unit the reader knows (``UNITS-BORE FURLONG``, a typo) had its bores read in the
coordinates' unit without a word; now it is refused naming the line, as an unknown UNITS-CO-ORDS is (which was
refused without its line)."""

from pathlib import Path

import pytest

from plantsolve.solvers.alignment.upload import parse_upload
from plantsolve.solvers.base import InputRejected, StoredInput

PCF = (Path(__file__).parents[3] / "examples" / "alignment" / "ladder.pcf").read_text()


@pytest.mark.parametrize(("record", "line"), [("UNITS-BORE", 2), ("UNITS-CO-ORDS", 3)])
def test_a_unit_record_naming_no_unit_is_refused_naming_its_line(record, line):
    text = PCF.replace(f"{record} MM", f"{record} MMM")
    with pytest.raises(InputRejected) as refused:
        parse_upload(StoredInput.from_bytes("ladder.pcf", text.encode()), None)
    (error,) = refused.value.errors
    assert error.loc == ("file",) and f"line {line}: {record} 'MMM'" in error.msg


@pytest.mark.parametrize("unit", ["mm", "Millimetre", "INCH-FRACTION"])
def test_the_spellings_read_are_still_read(unit):
    request = parse_upload(StoredInput.from_bytes("ladder.pcf", PCF.replace("UNITS-BORE MM", f"UNITS-BORE {unit}")
                                                  .encode()), None)
    assert len(request.components) == 19


def test_an_absurd_bore_is_unreadable_naming_its_line_not_a_refused_radius():
    from plantsolve.solvers.alignment.pcf import pcf_notes

    text = PCF.replace("10000.0000 100.0000", "10000.0000 1e300", 1)
    request = parse_upload(StoredInput.from_bytes("ladder.pcf", text.encode()), None)
    (note,) = [n for n in pcf_notes(request) if n[0] == "pcf_bore_unreadable"]
    assert "line 8 (1e300)" in note[1]
    assert all(c.radius is None or c.radius < 1e6 for c in request.components)
