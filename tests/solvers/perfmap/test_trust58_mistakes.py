"""Users' mistakes of the trust58 round that were read without a word: a speed line pasted a second time under the
next speed's value (the true line lost) is warned naming both settings and their lines; pyCycle's repeated alpha
planes (its maps without variable geometry) are no such mistake."""

from __future__ import annotations

from pathlib import Path

import pytest

from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.perfmap.upload import parse_upload
from plantsolve.solvers.perfmap.validation import load

DATA = Path(__file__).parent / "data"
EXAMPLES = Path(__file__).resolve().parents[3] / "examples" / "perfmap"
ROWS = [r.split(",") for r in (EXAMPLES / "n3_fan_map.csv").read_text().splitlines()[1:] if r.startswith("0.0,")]


def _loaded(name: str, data: bytes):
    source = StoredInput.from_bytes(name, data)
    return load(parse_upload(source, {"map": False}), source)


def _table(speeds: list[str]) -> bytes:
    """theta-0 speed lines of the example map, each taken from the speed its pair names: (written, measured)."""
    lines = ["speed [-],flow [lbm/s],pressure ratio [-],efficiency [-]"]
    for written, measured in speeds:
        lines += [",".join([written, *r[2:]]) for r in ROWS if r[1] == measured]
    return ("\n".join(lines) + "\n").encode()


def test_a_speed_line_pasted_under_the_next_speed_is_warned_naming_both_and_their_lines():
    pasted = _loaded("m.csv", _table([("0.5", "0.5"), ("0.7", "0.7"), ("0.8", "0.7"), ("0.9", "0.9")]))
    (warning,) = [w for w in pasted.warnings if w.code == "setting_lines_identical"]
    assert warning.details["pairs"] == [{"settings": [[0.7], [0.8]], "positions": [1, 2]}]
    n7 = sum(r[1] == "0.7" for r in ROWS)
    first = 2 + sum(r[1] == "0.5" for r in ROWS)  # the file line of the 0.7 line's first row
    assert f"speed=0.7 (lines {first}..{first + n7 - 1}) and speed=0.8 (lines {first + n7}..{first + 2 * n7 - 1})" \
        in warning.message
    measured = _loaded("m.csv", _table([("0.5", "0.5"), ("0.7", "0.7"), ("0.8", "0.8"), ("0.9", "0.9")]))
    assert "setting_lines_identical" not in {w.code for w in measured.warnings}


def test_a_pycycle_map_repeating_its_table_at_a_second_alpha_is_not_warned():
    text = (DATA / "pycycle" / "ncp01.py").read_bytes()
    loaded = _loaded("ncp01.py", text)
    assert len({s.values[0] for s in loaded.settings}) == 2  # two alpha planes, the same tables
    assert "setting_lines_identical" not in {w.code for w in loaded.warnings}


def test_flow_in_pounds_per_second_as_engine_decks_write_it_pps_is_lbm_per_s():
    """'pps' was refused as a length (pint's pico-parsec-seconds)."""
    def flows(unit: str) -> list[float]:
        text = "\n".join([f"speed [-],flow [{unit}],pressure ratio [-],efficiency [-]"]
                         + [",".join([r[1], *r[2:]]) for r in ROWS]) + "\n"
        source = StoredInput.from_bytes("m.csv", text.encode())
        request = parse_upload(source, {"map": False, "result_units": {"flow": "kg/s"}})
        return [v for p in load(request, source).internal.positions for v in p.flow]

    got = flows("pps")
    assert got == flows("lbm/s")
    assert got[0] == pytest.approx(float(ROWS[0][2]) * 0.45359237, rel=1e-12)
