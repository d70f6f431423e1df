"""A bare ``UNITS-CO-ORDS`` line (the record without its unit) left the coordinates' unit unknown, and joining the
end points failed on it: an upload got a generic 422, a JSON body's ``source_pcf`` crashed the worker. It is
refused naming the line."""

import re
from pathlib import Path

import pytest

from plantsolve.solvers.alignment.pcf import interpret_pcf
from plantsolve.solvers.alignment.upload import parse_upload
from plantsolve.solvers.base import InputRejected, StoredInput

PCF = (Path(__file__).parents[3] / "examples" / "alignment" / "ladder.pcf").read_text()
BARE = re.sub(r"(?m)^UNITS-CO-ORDS.*$", "UNITS-CO-ORDS", PCF)


@pytest.mark.parametrize(("text", "line"), [(BARE, 3), ("UNITS-CO-ORDS\n" + PCF, 1),
                                            (BARE.replace("UNITS-CO-ORDS", "units-co-ords"), 3)])
def test_a_bare_units_co_ords_is_refused_naming_its_line(text, line):
    with pytest.raises(InputRejected) as refused:
        parse_upload(StoredInput.from_bytes("ladder.pcf", text.encode()), None)
    (error,) = refused.value.errors
    assert error.loc == ("file",) and f"line {line}: UNITS-CO-ORDS names no unit" in error.msg


def test_a_json_bodys_bare_units_co_ords_is_refused_not_a_key_error():
    with pytest.raises(InputRejected, match="line 3: UNITS-CO-ORDS names no unit"):
        interpret_pcf(BARE, None)


def test_the_ladder_with_its_unit_is_still_read():
    assert len(parse_upload(StoredInput.from_bytes("ladder.pcf", PCF.encode()), None).components) == 19
