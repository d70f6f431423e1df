"""Perfmap: a rig table whose rows come in another order (or whose columns do, in a CSV or a workbook) is the same
map, its warnings included.

The reader numbered the speed lines in the order their first row appeared, and the warnings name a line by that
number (``details.position``): the N+3 fan map's rows shuffled moved 11 of its 12 `data_not_decreasing_concave`
warnings to other positions while the fits were the same bits.
"""

from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np
import openpyxl

from plantsolve.schemas.perfmap import PerfmapQueryRequest
from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.perfmap.query import answer_query
from plantsolve.solvers.perfmap.solve import solve
from plantsolve.solvers.perfmap.upload import parse_upload
from plantsolve.solvers.perfmap.validation import load

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "perfmap"
OPTIONS = {"grid": [16, 16]}  # a coarse max-efficiency map: the test is about the reader and the warnings


def _rows() -> tuple[list[str], list[list[str]]]:
    rows = list(csv.reader(io.StringIO((EXAMPLES / "n3_fan_map.csv").read_text())))
    return rows[0], rows[1:]


def _solved(path: Path, content: bytes):
    path.write_bytes(content)
    return solve(load(parse_upload(StoredInput.from_path(path), OPTIONS))).result


def _csv(header: list[str], rows: list[list[str]]) -> bytes:
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(header)
    writer.writerows(rows)
    return out.getvalue().encode()


def _xlsx(header: list[str], rows: list[list[str]]) -> bytes:
    book = openpyxl.Workbook()
    sheet = book.active
    sheet.append(header)
    for row in rows:
        sheet.append([float(v) for v in row])
    out = io.BytesIO()
    book.save(out)
    return out.getvalue()


def test_a_table_in_another_row_and_column_order_is_the_same_map_and_warnings(tmp_path):
    header, rows = _rows()
    as_written = _solved(tmp_path / "map.csv", _csv(header, rows))
    positions = [w.details["position"] for w in as_written.report.warnings if w.code == "data_not_decreasing_concave"]
    assert len(positions) == 12 and positions == sorted(positions)  # the lines in the order of their settings

    rng = np.random.default_rng(2)
    shuffled = [rows[i] for i in rng.permutation(len(rows))]
    cols = [4, 2, 0, 3, 1]
    reordered = _solved(tmp_path / "map.xlsx", _xlsx([header[j] for j in cols], [[r[j] for j in cols] for r in shuffled]))
    # the same bits: fits, map, beta tables, every warning with its details; only the format read differs
    assert reordered.report.details["source"].pop("format") == "xlsx"
    assert as_written.report.details["source"].pop("format") == "csv"
    assert reordered.model_dump(mode="json") == as_written.model_dump(mode="json")

    points = [{"flow": 2000.0, "pressure": 1.15}, {"flow": 2400.0, "pressure": 1.3}, {"flow": 1000.0, "pressure": 1.6}]
    answers = answer_query(as_written, PerfmapQueryRequest.model_validate({"points": points})).points
    backwards = answer_query(as_written, PerfmapQueryRequest.model_validate({"points": points[::-1]})).points
    assert [a.model_dump() for a in backwards[::-1]] == [a.model_dump() for a in answers]
