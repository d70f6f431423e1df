"""A pyCycle map whose NcMap holds per cent of design speed (50 to 115) is warned naming NcMap, as a GasTurb map's
speeds are: pyCycle's NcMap is relative (1.0 at design), and the map was read without a word. A table whose last
efficiency is cut to fewer decimals than its column's, in a column where a few cells (over 2 %) are that short,
is warned naming the column and the value, the row read as written: it was read without a word."""

from __future__ import annotations

import re

import numpy as np
import pytest

from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.perfmap.upload import parse_upload
from tests.solvers.perfmap.conftest import DATA

NCP01 = (DATA / "pycycle" / "ncp01.py").read_text()


def _codes(request) -> dict:
    return {w.code: w for w in request.upload_warnings}


def _percent_speeds(text: str) -> str:
    def scaled(m):
        return "NCP01.NcMap = np.array([" + ",".join(f"{100 * float(v):g}" for v in m.group(1).split(",")) + "])"
    return re.sub(r"NCP01\.NcMap = np\.array\(\[([^\]]*)\]\)", scaled, text)


def test_a_pycycle_ncmap_in_per_cent_is_warned_naming_ncmap():
    request = parse_upload(StoredInput.from_bytes("ncp01.py", _percent_speeds(NCP01).encode()), None)
    warning = _codes(request)["implausible_speed"]
    assert warning.details["table"] == "NcMap" and warning.details["values"] == [50.0, 115.0]
    assert "NcMap" in warning.message and "per cent" in warning.message


def test_a_pycycle_ncmap_of_relative_speeds_says_nothing():
    assert "implausible_speed" not in _codes(parse_upload(StoredInput.from_bytes("ncp01.py", NCP01.encode()), None))


def _table(short_cells: int) -> list[str]:
    """A speed-line table of 4-decimal efficiencies, ``short_cells`` of them with trailing zeros dropped (2 decimals),
    its last 0.8163."""
    rng = np.random.default_rng(3)
    lines = ["speed,flow [kg/s],pressure ratio,efficiency"]
    for i, (phi, k) in enumerate((phi, k) for phi in (0.6, 0.8, 1.0) for k in range(10)):
        eff = 0.80 + 0.01 * k - 0.001 * k * k + rng.uniform(0.0001, 0.0099)
        cell = f"{eff:.2f}0" if i < short_cells else f"{eff:.4f}"
        lines.append(f"{phi},{10 + 2 * k + 5 * phi:.3f},{1.2 + 0.05 * k * phi:.4f},{cell.rstrip('0')}")
    lines[-1] = lines[-1].rsplit(",", 1)[0] + ",0.8163"
    return lines


@pytest.mark.parametrize("short_cells", [1, 3])
def test_a_last_efficiency_cut_in_a_column_with_a_few_short_cells_is_warned_naming_the_column(short_cells):
    cut = "\n".join(_table(short_cells))[:-2]  # 0.8163 -> 0.81, no line ending
    request = parse_upload(StoredInput.from_bytes("m.csv", cut.encode()), None)
    warning = _codes(request)["truncated_file"]
    assert warning.details["column_name"] == "efficiency" and "'efficiency'" in warning.message
    assert 0.81 in request.positions[-1].efficiency  # read as written


def test_a_whole_last_row_says_nothing():
    request = parse_upload(StoredInput.from_bytes("m.csv", "\n".join(_table(3)).encode()), None)
    assert "truncated_file" not in _codes(request)
