"""A PCF whose UNITS records say INCH over a file written in millimetres (bores 100, arms 152.4, pipes 1000) read
every length 25.4 times too large, and every ratio the solve checks (a fitting's span in bores) still agreed: it was
solved without a word. Its bores say so: 100 is a DN size and no NPS. Warned (``pcf_bore_units``) naming the UNITS
record's line and the bores' lines; so is UNITS-BORE MM over NPS bores (4 for DN 100). A file in inches whose bores
are NPS sizes, or in millimetres with DN bores, says nothing."""

import re
from pathlib import Path

import pytest

from plantsolve.solvers.alignment.pcf import interpret_pcf
from plantsolve.solvers.alignment.pcf_bore_sizes import other_system_bores
from plantsolve.solvers.alignment.solve import solve
from plantsolve.solvers.alignment.upload import parse_upload
from plantsolve.solvers.base import StoredInput

LADDER = (Path(__file__).parents[3] / "examples" / "alignment" / "ladder.pcf").read_text()
LINE = ("ISOGEN-FILES ISOGEN.FLS\nUNITS-BORE MM\nUNITS-CO-ORDS MM\nPIPELINE-REFERENCE TEST-1\n"
        "PIPE\n    END-POINT 0.0000 0.0000 0.0000 100.0000\n    END-POINT 1000.0000 0.0000 0.0000 100.0000\n"
        "ELBOW\n    END-POINT 1000.0000 0.0000 0.0000 100.0000\n    END-POINT 1152.4000 152.4000 0.0000 100.0000\n"
        "    CENTRE-POINT 1152.4000 0.0000 0.0000\n"
        "PIPE\n    END-POINT 1152.4000 152.4000 0.0000 100.0000\n    END-POINT 1152.4000 1152.4000 0.0000 100.0000\n")


def _inch(text: str) -> str:
    return text.replace("UNITS-BORE MM", "UNITS-BORE INCH").replace("UNITS-CO-ORDS MM", "UNITS-CO-ORDS INCH")


def _bore_units(text: str):
    found = [(message, details) for code, message, details, _ in interpret_pcf(text, {}).notes
             if code == "pcf_bore_units"]
    return found[0] if found else None


def test_both_units_inch_over_a_millimetre_file_is_warned_naming_the_record_and_the_bores():
    report = solve(parse_upload(StoredInput.from_bytes("line.pcf", _inch(LINE).encode()), {})).result.report
    (warning,) = [w for w in report.warnings if w.code == "pcf_bore_units"]
    assert warning.details["line"] == 2 and warning.details["likely_unit"] == "mm"
    assert warning.details["bores"][0] == {"line": 6, "bore": 100.0}
    assert "line 2: UNITS-BORE INCH" in warning.message and "line 6 (100)" in warning.message


def test_units_co_ords_inch_alone_names_that_record():
    message, details = _bore_units(_inch(LADDER).replace("UNITS-BORE INCH\n", ""))
    assert (details["record"], details["line"]) == ("UNITS-CO-ORDS", 2) and "UNITS-CO-ORDS INCH" in message


def test_units_bore_mm_over_nps_bores_is_warned():
    message, details = _bore_units(LINE.replace(" 100.0000", " 4.0000"))
    assert details["likely_unit"] == "in" and "line 2: UNITS-BORE MM" in message


@pytest.mark.parametrize("text", [LINE, _inch(LINE.replace(" 100.0000", " 4.0000")), LADDER,
                                  _inch(re.sub(r" 100\.0000$", " 6.0000", LADDER, flags=re.M))])
def test_bores_of_the_stated_system_say_nothing(text):
    assert _bore_units(text) is None


@pytest.mark.parametrize(("bores", "unit", "other"), [
    ([100.0] * 3 + [40.0], "in", 3),  # NPS 40 is one
    ([2.0, 4.0, 6.0], "in", None),  # NPS sizes
    ([50.0, 65.0, 2.0, 3.0], "in", None),  # half of them: no majority
    ([0.5, 0.75, 1.0], "mm", 3),
    ([6.0, 8.0, 15.0], "mm", None),  # DN 6, 8, 15
    ([100.0], "m", None),  # only inch and millimetre bores are judged
])
def test_other_system_bores(bores, unit, other):
    found = other_system_bores(list(enumerate(bores, 1)), unit)
    assert (None if found is None else len(found[1])) == other
