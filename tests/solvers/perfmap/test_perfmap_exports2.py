"""The GasTurb map export read by the program that reads it: GSPy's own compressor map reader
(``TCompressorMap.ReadMap``, its interpolators built as GSPy builds them), kept verbatim in data/gspy_reader
(Apache-2.0, see data/README.md). A map our reader takes back but GSPy cannot load is not an export."""

from __future__ import annotations

import sys
from functools import cache
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.perfmap.cycle_exports import gasturb_tables
from plantsolve.solvers.perfmap.solve import solve
from plantsolve.solvers.perfmap.upload import parse_upload

DATA = Path(__file__).parent / "data"
REPO = Path(__file__).resolve().parents[3]


def gspy_compressor_map(folder: Path, name: str):
    """GSPy's compressor map object for ``folder/name``, read by GSPy's ReadMap (which also builds its cubic
    interpolators over (Nc, beta))."""
    sys.path.insert(0, str(DATA / "gspy_reader"))
    try:
        from gspy.core.compressormap import TCompressorMap
    finally:
        sys.path.remove(str(DATA / "gspy_reader"))
    owner = SimpleNamespace(maps_dir_path=folder, output_dir_path=folder)
    host = SimpleNamespace(owner=owner, station_in=2, name="compressor")
    gsp_map = TCompressorMap(host, "compressor map", name, None, None, "1", 1.0, 0.5)
    gsp_map.ReadMap(name)
    gsp_map.map_file.close()
    return gsp_map


@cache
def fitted_from(name: str, csv_speeds: tuple[float, ...] | None = None):
    """A fitted beta map: a GSPy sample map, or the example fan map cut to some speed lines of theta 0."""
    if csv_speeds is None:
        source = StoredInput.from_bytes(name, (DATA / "gasturb" / name).read_bytes())
        options = {"map": False, "beta_grid": {"lines": 21}}
    else:
        rows = (REPO / "examples" / "perfmap" / "n3_fan_map.csv").read_text().splitlines()
        kept = [rows[0]] + [r for r in rows[1:] if r.startswith("0.0,") and float(r.split(",")[1]) in csv_speeds]
        source = StoredInput.from_bytes(name, ("\n".join(kept) + "\n").encode())
        options = {"map": False}
    return solve(parse_upload(source, options)).result


def read_by_gspy(result, tmp_path):
    files = gasturb_tables(result)
    out = []
    for name, data in files.items():
        (tmp_path / name).write_bytes(data)
        out.append((name, gspy_compressor_map(tmp_path, name)))
    return out


@pytest.mark.parametrize("name", ["compmap.map", "bigfanc.map"])
def test_gspy_reads_the_export_of_its_own_sample_maps_as_the_fitted_beta_map(name, tmp_path):
    result = fitted_from(name)
    ((_, gsp),) = read_by_gspy(result, tmp_path)
    b = result.beta_map
    speeds = np.array([line.setting[-1] for line in b.lines])
    assert gsp.nc_values == pytest.approx(speeds, rel=5e-7) and gsp.beta_values == pytest.approx(b.beta, abs=5e-8)
    for table, quantity in ((gsp.wc_array, "flow"), (gsp.pr_array, "pressure"), (gsp.eta_array, "efficiency")):
        assert table == pytest.approx(np.array([getattr(line, quantity) for line in b.lines]), rel=5e-7)
    # GSPy's interpolators at the grid nodes give the map back (what a cycle run asks of it; scipy's cubic grid
    # interpolation solves for its spline iteratively, to about 1e-5)
    k, j = len(speeds) // 2, len(b.beta) // 3
    assert float(gsp.get_map_wc((speeds[k], b.beta[j]))) == pytest.approx(b.lines[k].flow[j], rel=1e-5)
    assert float(gsp.get_map_pr((speeds[k], b.beta[j]))) == pytest.approx(b.lines[k].pressure[j], rel=1e-5)
    surge = sorted((p.flow, p.pressure) for p in result.surge_line)
    assert np.column_stack([gsp.sl_wc_array, gsp.sl_pr_array[0]]) == pytest.approx(np.array(surge), rel=5e-7)


def test_gspy_loads_the_export_of_a_rig_table_of_nine_speed_lines(tmp_path):
    result = fitted_from("fan_9.csv", (0.5, 0.6, 0.7, 0.8, 0.9, 0.95, 1.0, 1.05, 1.1))
    assert "gasturb_below_gspy_minimum" not in {w.code for w in result.report.warnings}
    ((_, gsp),) = read_by_gspy(result, tmp_path)
    b = result.beta_map
    for line in b.lines:  # scipy's iterative cubic spline solve: within about 1e-4 at the nodes
        got = gsp.get_map_wc(np.column_stack([np.full(len(b.beta), line.setting[-1]), b.beta]))
        assert got == pytest.approx(line.flow, rel=1e-4)


def test_an_export_gspy_cannot_load_is_said_in_the_report():
    """GSPy interpolates cubically over (Nc, beta), which needs four values along each axis: with three speed lines
    its reader raises. The file is still written (this service's reader takes it back), and the report says GSPy
    cannot load it, instead of handing out a map file that the next tool refuses without a word."""
    result = fitted_from("fan_3.csv", (0.5, 0.8, 1.1))
    with pytest.raises(ValueError, match="requires at least +4 points"):
        gspy_compressor_map_of(result)
    (warning,) = [w for w in result.report.warnings if w.code == "gasturb_below_gspy_minimum"]
    assert warning.details["speed_lines"] == 3 and warning.details["minimum"] == 4
    assert "GSPy cannot load it" in warning.message


def gspy_compressor_map_of(result):
    import tempfile

    with tempfile.TemporaryDirectory() as folder:
        return read_by_gspy(result, Path(folder))


def test_a_beta_grid_of_three_lines_gspy_cannot_load_is_said_in_the_report():
    source = StoredInput.from_bytes("compmap.map", (DATA / "gasturb" / "compmap.map").read_bytes())
    result = solve(parse_upload(source, {"map": False, "beta_grid": {"lines": 3}})).result
    with pytest.raises(ValueError, match="requires at least +4 points"):
        gspy_compressor_map_of(result)
    (warning,) = [w for w in result.report.warnings if w.code == "gasturb_below_gspy_minimum"]
    assert warning.details["beta_values"] == 3 and "3 beta values" in warning.message
