"""The fitted map tabulated on (speed, beta) for cycle codes: a pyCycle ``MapData`` module, a GasTurb-style
text table and a long CSV, each with the surge and choke lines (written from ``result.beta_map``).

Layouts:

- ``map_pycycle.py``: ``alphaMap``, ``NcMap``, ``RlineMap`` and ``WcMap``/``PRmap``/``effMap`` indexed
  [alpha][Nc][R-line], R = 1 + 2 (1 - beta) ascending from ``RlineStall = 1`` (surge) to 3 (choke), as the
  maps shipped with pyCycle; the surge and choke lines as ``WcSurge``/``PRSurge``/``WcChoke``/``PRChoke``.
  Written when the settings are a full (alpha x speed) grid of at most two parameters; a map with one alpha
  (or speed only) is repeated at alpha + 90, as pyCycle's own maps without variable geometry are.
- ``map_gasturb.txt``: a ``99 title`` line, a ``Reynolds:`` line (no correction), then the blocks
  ``Mass Flow``, ``Efficiency``, ``Pressure Ratio``: each opens with ``R.CCC`` (R = speed lines + 1 rows,
  CCC = beta values + 1 columns) followed by the beta values, then one row per speed: the speed and its
  values. ``Surge Line`` (and ``Choke Line``) are 2-row tables: ``2.CCC`` and the flows, then ``1.0`` and
  the pressure ratios. One file per value of the leading settings (alpha) when there are several.
- ``map_beta.csv``: one row per (line, beta): the setting values, beta, flow, pressure, efficiency, with
  units in the headers; ``#`` lines say where the surge (beta = 1) and choke (beta = 0) lines are. The
  project's upload reader reads it back (beta is recognised and not needed).
"""

from __future__ import annotations

import io
import re

import numpy as np

from plantsolve.schemas.perfmap import PerfmapResult


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


def _limits_text(result: PerfmapResult) -> str:
    b = result.beta_map
    p = "parabolas" if b.exponent == 2 else "straight lines"
    return (f"beta lines: {p} y - {_g(b.vertex_pressure)} = c (x - {_g(b.vertex_flow)})^{b.exponent}; "
            "beta = 0 choke line, beta = 1 surge line")


def pycycle_module(result: PerfmapResult) -> bytes | None:
    """A pyCycle ``MapData`` module of the beta grid; None when the settings are no full grid of at most two
    parameters (pyCycle's tables are rectangular in alpha x Nc)."""
    if len(result.setting_names) > 2:
        return None
    gs = groups(result)
    speeds = [tuple(result.beta_map.lines[k].setting[-1] for k in ks) for _, ks in gs]
    if any(s != speeds[0] for s in speeds):
        return None
    beta = np.array(result.beta_map.beta)
    order = np.argsort(-beta, kind="stable")  # surge (R-line 1) first
    rline = 1.0 + 2.0 * (1.0 - beta[order])
    W, P, E = (np.stack([t[:, order] for t in tabs]) for tabs in zip(*(_tables(result, ks) for _, ks in gs)))
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

    surge = np.array([[result.beta_map.lines[k].flow[-1], result.beta_map.lines[k].pressure[-1]]
                      for _, ks in gs for k in ks])
    choke = np.array([[result.beta_map.lines[k].flow[0], result.beta_map.lines[k].pressure[0]]
                      for _, ks in gs for k in ks])
    names = ", ".join(result.setting_names)
    repeat_note = (f"\nThe map has one alpha: its table is repeated at alpha {_g(alpha[1])}, as pyCycle's maps without "
                   "variable geometry do." if repeated else "")
    text = f'''import numpy as np

from pycycle.maps.map_data import MapData


"""Compressor map exported by plantsolve perfmap from the fitted speed lines ({names}).
WcMap: flow {_unit(result, "flow")}, PRmap: pressure {_unit(result, "pressure")}, effMap: a fraction.
R-line R = 1 + 2 (1 - beta): RlineStall = 1 is the surge line, R = 3 the choke line;
{_limits_text(result)}.{repeat_note}"""
ExportMap = MapData()

# Map design point values: the node of highest efficiency
ExportMap.defaults = {{}}
ExportMap.defaults['alphaMap'] = {_g(alpha[a])}
ExportMap.defaults['NcMap'] = {_g(speeds[0][n])}
ExportMap.defaults['PR'] = {_g(P[a, n, r])}
ExportMap.defaults['RlineMap'] = {_g(rline[r])}
ExportMap.RlineStall = 1.0

ExportMap.alphaMap = np.array([{", ".join(_g(v) for v in alpha)}])
ExportMap.NcMap = np.array([{", ".join(_g(v) for v in speeds[0])}])
ExportMap.RlineMap = np.array([{", ".join(_g(v) for v in rline)}])

ExportMap.WcMap = {array(W)}

ExportMap.PRmap = {array(P)}

ExportMap.effMap = {array(E)}

# surge line (R-line 1) and choke line (R-line 3), one point per (alpha, Nc) in the order of the tables
ExportMap.WcSurge = np.array([{", ".join(_g(v) for v in surge[:, 0])}])
ExportMap.PRSurge = np.array([{", ".join(_g(v) for v in surge[:, 1])}])
ExportMap.WcChoke = np.array([{", ".join(_g(v) for v in choke[:, 0])}])
ExportMap.PRChoke = np.array([{", ".join(_g(v) for v in choke[:, 1])}])
'''
    return text.encode()


def _block(title: str, beta: np.ndarray, speeds: list[float], table: np.ndarray) -> list[str]:
    out = [title, f"{len(speeds) + 1:>12d}.{len(beta) + 1:03d}" + "".join(f"{v:>14.6f}" for v in beta)]
    out += [f"{s:>16.6g}" + "".join(f"{v:>14.7g}" for v in row) for s, row in zip(speeds, table)]
    return out + [""]


def _line_block(title: str, x: np.ndarray, y: np.ndarray) -> list[str]:
    return [title, f"{2:>12d}.{len(x) + 1:03d}" + "".join(f"{v:>14.7g}" for v in x),
            f"{1.0:>16.6f}" + "".join(f"{v:>14.7g}" for v in y), ""]


def gasturb_tables(result: PerfmapResult) -> dict[str, bytes]:
    """GasTurb-style map text per value of the leading settings: {file name: bytes}."""
    beta = np.array(result.beta_map.beta)
    out = {}
    gs = groups(result)
    for key, ks in gs:
        W, P, E = _tables(result, ks)
        speeds = [result.beta_map.lines[k].setting[-1] for k in ks]
        where = ", ".join(f"{n}={_g(v)}" for n, v in zip(result.setting_names[:-1], key))
        # no block keyword in the title: readers find the blocks by scanning for them
        b = result.beta_map
        title = (f"99    plantsolve perfmap compressor map{' (' + where + ')' if where else ''}; flow "
                 f"{_unit(result, 'flow')}, pressure {_unit(result, 'pressure')}; beta 0 at choke, 1 at surge, "
                 f"beta lines y - {_g(b.vertex_pressure)} = c (x - {_g(b.vertex_flow)})^{b.exponent}")
        surge, choke = np.argsort(W[:, -1]), np.argsort(W[:, 0])
        text = [title, "Reynolds: RNI=1 f=1 RNI=1 f=1"]
        text += _block("Mass Flow", beta, speeds, W) + _block("Efficiency", beta, speeds, E)
        text += _block("Pressure Ratio", beta, speeds, P)
        text += _line_block("Surge Line", W[surge, -1], P[surge, -1])
        text += _line_block("Choke Line", W[choke, 0], P[choke, 0])
        tag = "_".join(f"{n}{_g(v)}" for n, v in zip(result.setting_names[:-1], key))
        # a file name, whatever the setting is called ('IGV [deg]', 'N/sqrt(T)')
        name = "map_gasturb.txt" if len(gs) == 1 else f"map_gasturb_{re.sub(r'[^A-Za-z0-9.+-]+', '_', tag)}.txt"
        out[name] = "\n".join(text).encode()
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
