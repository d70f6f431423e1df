"""The cycle-code exports of a rig table uploaded in the user's units and converted (options.result_units), read by
the next tool itself: pyCycle's CompressorMap (an OpenMDAO problem) on map_pycycle.py, and GSPy's own map reader on
map_gasturb.map, with an adaptive and an even beta grid. The fitted beta map is the reference; pyCycle converts
the declared unit back to the rig's lbm/s, GSPy takes the numbers as written (kg/s, as the export's title says)."""

from __future__ import annotations

from functools import cache
from pathlib import Path

import numpy as np
import pytest

from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.perfmap.cycle_exports import pycycle_module
from plantsolve.solvers.perfmap.solve import solve
from plantsolve.solvers.perfmap.upload import parse_upload
from tests.solvers.perfmap.test_perfmap_exports2 import read_by_gspy
from tests.solvers.perfmap.test_perfmap_pycycle_maps import _load, _problem

EXAMPLES = Path(__file__).resolve().parents[3] / "examples" / "perfmap"
LB = 0.45359237  # kg per lbm
SPEEDS = ("0.5", "0.7", "0.9", "1.1")  # four lines: GSPy's cubic interpolation needs four along each axis


@cache
def fitted(spacing: str):
    """Four speed lines of the example fan map (theta 0), its flow stated in lbm/s in the header, fitted with the
    result asked in kg/s."""
    rows = (EXAMPLES / "n3_fan_map.csv").read_text().splitlines()
    kept = [r for r in rows[1:] if r.split(",")[0] == "0.0" and r.split(",")[1] in SPEEDS]
    text = "\n".join(["theta [deg],Nc [-],flow [lbm/s],pressure ratio [-],efficiency [-]", *kept]) + "\n"
    request = parse_upload(StoredInput.from_bytes("rig.csv", text.encode()),
                           {"map": False, "result_units": {"flow": "kg/s"}, "beta_grid": {"spacing": spacing}})
    return solve(request).result


@pytest.mark.parametrize("spacing", ["adaptive", "even"])
def test_pycycle_reads_the_converted_export_back_in_the_rigs_lbm_per_s(spacing):
    result = fitted(spacing)
    assert result.units.flow == "kg/s" and result.beta_map.spacing == spacing
    module = _load(pycycle_module(result).decode())
    assert module.units["WcMap"] == "kg/s"
    p = _problem(module, design=True)
    beta = np.array(result.beta_map.beta)
    line = result.beta_map.lines[2]  # Nc 0.9
    for j in (1, len(beta) // 2, len(beta) - 2):  # nodes near choke, mid-line and near surge
        p.set_val("alphaMap", line.setting[0])
        p.set_val("NcMap", line.setting[-1], units="rpm")
        p.set_val("RlineMap", 1.0 + 2.0 * (1.0 - beta[j]))
        p.run_model()
        assert p.get_val("WcMap", units="lbm/s")[0] == pytest.approx(line.flow[j] / LB, rel=1e-9)
        assert p.get_val("PRmap")[0] == pytest.approx(line.pressure[j], rel=1e-9)
        assert p.get_val("effMap")[0] == pytest.approx(line.efficiency[j], rel=1e-9)
    # the rig's numbers: the flows of the example's 0.9 line, in lbm/s, span what pyCycle reads along the line
    rig = [float(r.split(",")[2]) for r in (EXAMPLES / "n3_fan_map.csv").read_text().splitlines()[1:]
           if r.startswith("0.0,0.9,")]
    assert min(rig) * 0.97 < min(line.flow) / LB and max(line.flow) / LB < max(rig) * 1.03


@pytest.mark.parametrize("spacing", ["adaptive", "even"])
def test_gspy_reads_the_converted_export_as_the_fitted_map_in_kg_per_s(spacing, tmp_path):
    result = fitted(spacing)
    ((name, gsp),) = read_by_gspy(result, tmp_path)
    assert "flow [kg/s]" in (tmp_path / name).read_text().splitlines()[0]
    b = result.beta_map
    assert gsp.nc_values == pytest.approx([line.setting[-1] for line in b.lines], rel=5e-7)
    assert gsp.beta_values == pytest.approx(b.beta, abs=5e-8)
    assert gsp.wc_array == pytest.approx(np.array([line.flow for line in b.lines]), rel=5e-7)
    assert gsp.pr_array == pytest.approx(np.array([line.pressure for line in b.lines]), rel=5e-7)
    assert gsp.eta_array == pytest.approx(np.array([line.efficiency for line in b.lines]), rel=5e-7)
