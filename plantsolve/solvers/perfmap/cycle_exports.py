"""The fitted map tabulated on (speed, beta) for cycle codes: a pyCycle ``MapData`` module, a GasTurb/GSP
map table and a long CSV, each with the surge and choke lines (written from ``result.beta_map``).

Layouts:

- ``map_pycycle.py``: a module in the layout of pyCycle's own maps (``pycycle/maps/*.py``) that its
  ``CompressorMap(map_data=ExportMap)`` runs as it is: ``alphaMap``, ``NcMap``, ``RlineMap`` and
  ``WcMap``/``effMap``/``PRmap`` indexed [alpha][Nc][R-line], R = 1 + 2 (1 - beta) ascending from
  ``RlineStall = 1`` (surge) to 3 (choke); ``defaults`` (the design point, under the map's own names), ``units``
  and the ``param_data``/``output_data`` lists its interpolators are built from; the surge and choke lines as
  ``WcSurge``/``PRSurge``/``WcChoke``/``PRChoke``. Written when the settings are a full (alpha x speed) grid of at
  most two parameters; a map with one alpha (or speed only) is repeated at alpha + 90, as pyCycle's own maps
  without variable geometry are. WcMap carries the fitted flow unit in OpenMDAO's spelling (a mass flow: kg/s,
  lbm/s, ...; another mass-flow unit is converted to kg/s); without a mass-flow unit it has none.
- ``map_gasturb.map``: the layout of GasTurb's and GSP's maps, under the extension their map files have (GSPy's
  sample maps, GSP's map dialogs), read back by
  :mod:`~plantsolve.solvers.perfmap.gasturb_map`): a ``99 title`` line, a ``Reynolds:`` line (no correction),
  then the tables ``Mass Flow``, ``Efficiency``, ``Pressure Ratio``: each opens with its key ``R.CCC``
  (R = speed lines + 1 rows, CCC = beta values + 1 columns) and the first four beta values, five values a line
  after that; each speed starts a line with its first four values; ``Surge Line`` (and ``Choke Line``) are
  2-row tables: ``2.CCC`` and the flows, then ``1.0`` and the pressure ratios. A blank line closes each table.
  One file per value of the leading settings (alpha) when there are several (``map_gasturb_<setting><value>.map``).
  GSP reads at most 40 values a table row and 150 rows (its "Map table format" page): beta_grid.lines stops at 40,
  and a group of more than 40 speed lines (its Surge Line table holds one flow per line) is written with the
  result's ``gasturb_beyond_gsp_limits`` warning.
- ``map_beta.csv``: one row per (line, beta): the setting values, beta, flow, pressure, efficiency, with
  units in the headers; ``#`` lines say where the surge (beta = 1) and choke (beta = 0) lines are. The
  project's upload reader reads it back (beta is recognised and not needed).
"""

from __future__ import annotations

import io
import re

import numpy as np
import pint

from plantsolve.schemas.perfmap import PerfmapResult
from plantsolve.solvers.perfmap.units import UnitError, check_quantity, parse_unit


def _g(v: float) -> str:
    return f"{float(v):.10g}"


def groups(result: PerfmapResult) -> list[tuple[tuple[float, ...], list[int]]]:
    """(leading setting values, line indices by ascending speed) per value of all settings but the last."""
    lines = result.beta_map.lines
    out: dict[tuple[float, ...], list[int]] = {}
    for k, line in enumerate(lines):
        out.setdefault(tuple(line.setting[:-1]), []).append(k)
    return [(key, sorted(ks, key=lambda k: lines[k].setting[-1])) for key, ks in sorted(out.items())]


def _tables(result: PerfmapResult, ks: list[int]):
    lines = result.beta_map.lines
    return (np.array([lines[k].flow for k in ks]), np.array([lines[k].pressure for k in ks]),
            np.array([lines[k].efficiency for k in ks]))


def _unit(result: PerfmapResult, quantity: str) -> str:
    u = getattr(result.units, quantity, None) if result.units else None
    return "unit not stated" if not u else "[-]" if u in ("1", "-") else f"[{u}]"


def _speed_unit(result: PerfmapResult) -> str:
    """', speed [rpm]' where the speed lines are in a unit of their own (rpm, %): the speed column of a GasTurb map
    is a relative speed, and the title is where the file can say otherwise (this service's .map reader reads it)."""
    units = result.units.settings if result.units else []
    u = units[-1] if units else None
    return "" if not u or u in ("1", "-") else f", speed [{u}]"


def _limits_text(result: PerfmapResult) -> str:
    b = result.beta_map
    p = "parabolas" if b.exponent == 2 else "straight lines"
    table = ("" if b.table_pressure_max_rel_error is None else
             f"; read linearly between nodes the table is within {100 * b.table_pressure_max_rel_error:.2g} % of the "
             "fitted pressure")
    return (f"beta lines: {p} y - {_g(b.vertex_pressure)} = c (x - {_g(b.vertex_flow)})^{b.exponent}; "
            f"beta = 0 choke line, beta = 1 surge line{table}")


# OpenMDAO spellings of the mass-flow units pyCycle's CompressorMap converts (its own maps state lbm/s), with their
# value in kg/s; another mass-flow unit is written converted to kg/s
_OPENMDAO_FLOW_UNITS = {"kg/s": 1.0, "g/s": 1e-3, "kg/min": 1 / 60, "kg/h": 1 / 3600, "t/h": 1 / 3.6,
                        "lbm/s": 0.45359237, "lbm/min": 0.45359237 / 60, "lbm/h": 0.45359237 / 3600}


def _pycycle_flow_unit(result: PerfmapResult) -> tuple[str | None, float, str]:
    """(OpenMDAO unit of WcMap or None, factor applied to the flows, a sentence for the module docstring)."""
    stated = result.units.flow if result.units else None
    if not stated:
        return None, 1.0, ("the flow unit was not stated: WcMap has no units (OpenMDAO warns and takes it as\n"
                           "CompressorMap's lbm/s); set ExportMap.units['WcMap'] to its unit")
    try:
        to_kg_s = check_quantity("flow", stated)
        factor = to_kg_s.factor_to(parse_unit("kg/s")) if to_kg_s is not None else None
    except (UnitError, pint.errors.DimensionalityError):
        factor = None
    if factor is None:
        return None, 1.0, (f"the flow is in {stated}, not a mass flow: WcMap has no units (OpenMDAO warns and takes "
                           "it as CompressorMap's lbm/s)")
    for name, kg_s in _OPENMDAO_FLOW_UNITS.items():
        if abs(factor / kg_s - 1.0) < 1e-12:
            return name, 1.0, f"WcMap in {name} (the fitted map's {stated})"
    return "kg/s", factor, f"WcMap in kg/s: the fitted map's {stated} times {_g(factor)}"


def pycycle_module(result: PerfmapResult) -> bytes | None:
    """A pyCycle ``MapData`` module of the beta grid, in the layout of pyCycle's own map modules: everything its
    ``CompressorMap`` reads (``param_data``/``output_data`` for the interpolators, ``defaults``, ``RlineStall``)
    and the surge and choke lines. None when the settings are no full grid of at most two parameters (pyCycle's
    tables are rectangular in alpha x Nc) or hold one speed line (its interpolation needs two)."""
    if len(result.setting_names) > 2:
        return None
    gs = groups(result)
    speeds = [tuple(result.beta_map.lines[k].setting[-1] for k in ks) for _, ks in gs]
    if any(s != speeds[0] for s in speeds) or len(speeds[0]) < 2:  # one speed line: no table OpenMDAO takes
        return None
    beta = np.array(result.beta_map.beta)
    order = np.argsort(-beta, kind="stable")  # surge (R-line 1) first
    rline = 1.0 + 2.0 * (1.0 - beta[order])
    W, P, E = (np.stack([t[:, order] for t in tabs]) for tabs in zip(*(_tables(result, ks) for _, ks in gs)))
    flow_unit, flow_factor, flow_note = _pycycle_flow_unit(result)
    W = W * flow_factor
    alpha = [key[0] if key else 0.0 for key, _ in gs]
    a, n, r = np.unravel_index(int(np.argmax(E)), E.shape)
    repeated = len(alpha) == 1
    if repeated:  # pyCycle interpolates in alpha too, which needs two values: its own maps repeat the table
        alpha = [alpha[0], alpha[0] + 90.0]
        W, P, E = (np.concatenate([v, v]) for v in (W, P, E))

    def array(a3: np.ndarray) -> str:
        return "np.array([" + ",\n  ".join(
            "[" + ",\n   ".join("[" + ", ".join(_g(v) for v in row) + "]" for row in plane) + "]"
            for plane in a3) + "])"

    def vector(v) -> str:
        return "np.array([" + ", ".join(_g(x) for x in v) + "])"

    surge = np.array([[result.beta_map.lines[k].flow[-1], result.beta_map.lines[k].pressure[-1]]
                      for _, ks in gs for k in ks])
    choke = np.array([[result.beta_map.lines[k].flow[0], result.beta_map.lines[k].pressure[0]]
                      for _, ks in gs for k in ks])
    surge[:, 0] *= flow_factor
    choke[:, 0] *= flow_factor
    names = ", ".join(result.setting_names)
    repeat_note = (f"\nThe map has one alpha: its table is repeated at alpha {_g(alpha[1])}, as pyCycle's maps without "
                   "variable geometry do." if repeated else "")
    text = f'''import numpy as np

from pycycle.maps.map_data import MapData


"""Compressor map exported by plantsolve perfmap from the fitted speed lines ({names}), for pyCycle's
CompressorMap(map_data=ExportMap). NcMap: the speed lines' values (CompressorMap labels them rpm);
{flow_note};
PRmap: pressure {_unit(result, "pressure")}; effMap: a fraction.
R-line R = 1 + 2 (1 - beta): RlineStall = 1 is the surge line, R = 3 the choke line;
{_limits_text(result)}.{repeat_note}"""
ExportMap = MapData()

# Map design point values: the node of highest efficiency
ExportMap.defaults = {{}}
ExportMap.defaults['alphaMap'] = {_g(alpha[a])}
ExportMap.defaults['NcMap'] = {_g(speeds[0][n])}
ExportMap.defaults['RlineMap'] = {_g(rline[r])}
ExportMap.defaults['WcMap'] = {_g(W[a, n, r])}
ExportMap.defaults['PRmap'] = {_g(P[a, n, r])}
ExportMap.defaults['effMap'] = {_g(E[a, n, r])}
ExportMap.RlineStall = 1.0

ExportMap.alphaMap = {vector(alpha)}
ExportMap.NcMap = {vector(speeds[0])}
ExportMap.RlineMap = {vector(rline)}

ExportMap.WcMap = {array(W)}

ExportMap.effMap = {array(E)}

ExportMap.PRmap = {array(P)}

# surge line (R-line 1) and choke line (R-line 3), one point per (alpha, Nc) in the order of the tables
ExportMap.WcSurge = {vector(surge[:, 0])}
ExportMap.PRSurge = {vector(surge[:, 1])}
ExportMap.WcChoke = {vector(choke[:, 0])}
ExportMap.PRChoke = {vector(choke[:, 1])}

ExportMap.units = {{}}
ExportMap.units['NcMap'] = 'rpm'
ExportMap.units['WcMap'] = {flow_unit!r}

ExportMap.Npts = ExportMap.NcMap.size

# format for the regular grid interpolator

ExportMap.param_data = []
ExportMap.output_data = []

ExportMap.param_data.append({{'name': 'alphaMap', 'values': ExportMap.alphaMap,
                             'default': ExportMap.defaults['alphaMap'], 'units': None}})
ExportMap.param_data.append({{'name': 'NcMap', 'values': ExportMap.NcMap,
                             'default': ExportMap.defaults['NcMap'], 'units': ExportMap.units['NcMap']}})
ExportMap.param_data.append({{'name': 'RlineMap', 'values': ExportMap.RlineMap,
                             'default': ExportMap.defaults['RlineMap'], 'units': None}})

ExportMap.output_data.append({{'name': 'WcMap', 'values': ExportMap.WcMap,
                              'default': ExportMap.defaults['WcMap'], 'units': ExportMap.units['WcMap']}})
ExportMap.output_data.append({{'name': 'effMap', 'values': ExportMap.effMap,
                              'default': ExportMap.defaults['effMap'], 'units': None}})
ExportMap.output_data.append({{'name': 'PRmap', 'values': ExportMap.PRmap,
                              'default': ExportMap.defaults['PRmap'], 'units': None}})
'''
    return text.encode()


def _wrapped(first: list[str], rest: list[str]) -> list[str]:
    """One record of a GasTurb table: ``first`` (the key or a speed) and four values on its line, then five
    values a line (the published layout; readers split at blanks, so each value has one before it)."""
    head = " ".join(first + rest[:4])
    return [head] + [" ".join(rest[i:i + 5]) for i in range(4, len(rest), 5)]


def _num(v: float) -> str:
    # ten digits: at a steep choke end a flow rounded to seven would move the pressure read back by 1e-5, more
    # than the table error the result states leaves room for (readers take any width: values are blank-separated)
    return f"{float(v):16.10g}"


def _block(title: str, beta: np.ndarray, speeds: list[float], table: np.ndarray) -> list[str]:
    out = [title] + _wrapped([f"{len(speeds) + 1:9d}.{len(beta) + 1:03d}"], [_num(v) for v in beta])
    for s, row in zip(speeds, table):
        out += _wrapped([_num(s)], [_num(v) for v in row])
    return out + [""]


def _line_block(title: str, x: np.ndarray, y: np.ndarray) -> list[str]:
    return ([title] + _wrapped([f"{2:9d}.{len(x) + 1:03d}"], [_num(v) for v in x])
            + _wrapped([_num(1.0)], [_num(v) for v in y]) + [""])


def gasturb_tables(result: PerfmapResult) -> dict[str, bytes]:
    """GasTurb map text per value of the leading settings: {file name: bytes}. The layout of GasTurb's and GSP's
    own maps: each table is its title, then the key (rows + columns / 1000) and the first four beta values on
    one line, five values a line after that; each speed starts a line with its first four values; a blank line
    closes every table."""
    beta = np.array(result.beta_map.beta)
    out = {}
    gs = groups(result)
    for key, ks in gs:
        W, P, E = _tables(result, ks)
        speeds = [result.beta_map.lines[k].setting[-1] for k in ks]
        where = ", ".join(f"{n}={_g(v)}" for n, v in zip(result.setting_names[:-1], key))
        # no table keyword in the title: readers find the tables by scanning for them
        b = result.beta_map
        title = (f"99    plantsolve perfmap compressor map{' (' + where + ')' if where else ''}; flow "
                 f"{_unit(result, 'flow')}, pressure {_unit(result, 'pressure')}{_speed_unit(result)}; beta 0 at "
                 "choke, 1 at surge, "
                 f"beta lines y - {_g(b.vertex_pressure)} = c (x - {_g(b.vertex_flow)})^{b.exponent}"
                 + ("" if b.table_pressure_max_rel_error is None else
                    f"; table within {100 * b.table_pressure_max_rel_error:.2g} % of the fitted pressure"))
        surge, choke = np.argsort(W[:, -1]), np.argsort(W[:, 0])
        text = [title, "Reynolds: RNI=1 f=1 RNI=1 f=1"]
        text += _block("Mass Flow", beta, speeds, W) + _block("Efficiency", beta, speeds, E)
        text += _block("Pressure Ratio", beta, speeds, P)
        text += _line_block("Surge Line", W[surge, -1], P[surge, -1])
        text += _line_block("Choke Line", W[choke, 0], P[choke, 0])
        tag = "_".join(f"{n}{_g(v)}" for n, v in zip(result.setting_names[:-1], key))
        # a file name, whatever the setting is called ('IGV [deg]', 'N/sqrt(T)')
        name = "map_gasturb.map" if len(gs) == 1 else f"map_gasturb_{re.sub(r'[^A-Za-z0-9.+-]+', '_', tag)}.map"
        out[name] = ("\n".join(text) + "\n").encode()
    return out


def beta_csv(result: PerfmapResult, setting_headers: list[str], flow_header: str, pressure_header: str) -> bytes:
    """Long form: one row per (speed line, beta)."""
    b = result.beta_map
    buf = io.StringIO()
    buf.write(f"# plantsolve perfmap beta grid; {_limits_text(result)}\n")
    buf.write(f"# surge line: the {len(b.lines)} rows with beta = 1; choke line: the rows with beta = 0\n")
    buf.write(",".join([*setting_headers, "beta [-]", flow_header, pressure_header, "efficiency [-]"]) + "\n")
    for _, ks in groups(result):
        for k in ks:
            line = b.lines[k]
            for j, beta in enumerate(b.beta):
                buf.write(",".join([*(repr(float(v)) for v in line.setting), repr(float(beta)),
                                    repr(line.flow[j]), repr(line.pressure[j]), repr(line.efficiency[j])]) + "\n")
    return buf.getvalue().encode()
