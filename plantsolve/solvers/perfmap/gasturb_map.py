"""GasTurb / GSP compressor and fan map files (``.map``) read into speed lines.

The layout GasTurb writes and GSP and GSPy read:

- a first line with the map type indicator and a title (``99    Sample Axial compressor map``); 99 is the usual
  type, any whole number is taken (the type is reported);
- ``Reynolds: RNI=x1 f=y1 RNI=x2 f=y2`` (optional): the cycle code's Reynolds-number correction, reported and
  not applied (the tables are the map at its reference Reynolds number);
- tables, each under its keyword line: ``Mass Flow``, ``Efficiency``, ``Pressure Ratio`` (beta the argument, the
  speed the parameter), ``Surge Line`` and optionally ``Choke Line`` (corrected flows the arguments, then one row
  of pressure ratios). A table is a key, ``rows + columns / 1000`` (rows = speeds + 1, columns = arguments + 1),
  the arguments, then per speed the speed and its values. The published layout puts the key and four values on
  a line and five a line after that, every speed starting a line; files that write each record on one line read
  the same. A blank line (or the next keyword) closes a table.
- A map with variable geometry holds one such set of tables per geometry setting, each set after a line naming
  the setting (``VG angle = -5``, ``Alpha: 10``): the setting is then a second parameter before the speed.

A turbine map (``Min Pressure Ratio``/``Max Pressure Ratio`` tables) is refused naming what it is: perfmap fits
compressor characteristics (pressure falling with flow). The speed is GasTurb's relative corrected speed
(N/sqrt(T) over its map reference value, dimensionless) and the flow the corrected mass flow W sqrt(T)/P; the file
states no flow unit, so the upload's ``units`` option (``{"flow": "kg/s"}``) or a ``flow [unit]`` in the title
(as this package's own export writes) states it, else the result says none. Each beta point of a speed line is a
measured point; the beta values themselves are reported and not needed.

Every refusal names the line (``("file", "line", n)``, or ``("file", "row", n, field)`` for a value); a file
that ends inside a speed table is refused as ``truncated_file``, one that ends inside a limit line (surge, choke)
is read with a ``truncated_file`` warning.
"""

from __future__ import annotations

import difflib
import math
import re
from dataclasses import dataclass, field

import numpy as np
import pint

from plantsolve.schemas.common import MAX_MEASURED, Diagnostic
from plantsolve.solvers.base import FieldError, InputRejected, decode_text, reject
from plantsolve.solvers.perfmap.speed_names import named_as_speed
from plantsolve.solvers.perfmap.setting_lines import CHOKE_FLOW_TOLERANCE
from plantsolve.solvers.perfmap.units import UnitError, check_quantity, parse_speed_unit, revolutions_per_minute
from plantsolve.solvers.skipped_input import truncated_file

SPEED_TABLES = ("Mass Flow", "Efficiency", "Pressure Ratio")
LIMIT_TABLES = ("Surge Line", "Choke Line")
TURBINE_TABLES = ("Min Pressure Ratio", "Max Pressure Ratio")
_KEYWORDS = {k.lower(): k for k in SPEED_TABLES + LIMIT_TABLES + TURBINE_TABLES}
# bounds on a table's key: a garbled key must not make the reader allocate for millions of values; GSP itself
# reads at most 40 arguments (beta values, or the flows of a limit line) and 150 parameters (speeds) a table
MAX_ARGUMENTS = 200
MAX_ROWS = 2000
GSP_MAX_ARGUMENTS = 40
GSP_MAX_PARAMETERS = 150
MAX_DROPPED_NAMED = 20  # map points left out named with their table, line, speed and beta in the warning
MAX_RELATIVE_SPEED = 3.0  # relative corrected speeds above this are percent or rpm (implausible_speed)
_DECIMAL_COMMA = re.compile(r"^[+-]?\d+,\d+([eEdD][+-]?\d+)?$")
_SETTING_LINE = re.compile(r"^\s*([A-Za-z][^:=]*?)\s*[:=]\s*([-+]?(?:\d+(?:[.,]\d*)?|[.,]\d+)(?:[eE][-+]?\d+)?)\s*"
                           r"(?:\[([^\]]*)\])?\s*$")
_TITLE_UNIT = re.compile(r"\b(flow|pressure)\s*\[([^\]]+)\]", re.IGNORECASE)
# this service's export states a speed that is no relative speed (rpm, %) in its title: 'speed [rpm]'
_TITLE_SPEED = re.compile(r";\s*flow\b[^;]*?,\s*speed\s*\[([^\]]+)\]", re.IGNORECASE)
_REYNOLDS = re.compile(r"RNI\s*=\s*(\S+?)\s+f\s*=\s*(\S+)", re.IGNORECASE)


@dataclass
class Table:
    """One table of the file: its keyword, the arguments (beta, or flows for a limit line), the parameters
    (speeds) and the values [parameter][argument], with the file line of the keyword and of each value."""

    name: str
    line: int
    args: np.ndarray
    params: np.ndarray
    values: np.ndarray
    value_lines: np.ndarray
    param_lines: list[int]
    heading: str = ""  # the keyword line as written ('Mass Flow [kg/s]')


@dataclass
class TableSet:
    """The tables of one geometry setting (all of the file when it has no setting lines)."""

    setting: float | None = None
    label: str = ""
    unit: str = ""
    line: int = 0
    tables: dict[str, Table] = field(default_factory=dict)


def _number(token: str) -> float:
    """A number as map files write it: decimal point, or a decimal comma (no separator can be a comma here:
    values are separated by blanks), a Fortran ``D`` exponent."""
    t = token.strip()
    if _DECIMAL_COMMA.match(t):
        t = t.replace(",", ".")
    return float(t.replace("D", "E").replace("d", "e"))


def _is_number(token: str) -> bool:
    try:
        _number(token)
        return True
    except ValueError:
        return False


class _Lines:
    """The file's lines with a cursor; line numbers are 1-based, as an editor shows them."""

    def __init__(self, text: str):
        self.lines = text.splitlines()
        self.i = 0

    def done(self) -> bool:
        return self.i >= len(self.lines)

    def number(self) -> int:
        return self.i + 1

    def peek(self) -> str:
        return self.lines[self.i]


def _keyword(line: str) -> str | None:
    """The table keyword a line names: the keyword alone, or followed by a note or unit after a blank, colon or
    bracket ('Mass Flow [kg/s]', 'Efficiency: isentropic'); the longest keyword first ('Min Pressure Ratio' is
    not 'Pressure Ratio')."""
    key = re.sub(r"\s+", " ", line.strip().rstrip(":").strip()).lower()
    if key in _KEYWORDS:
        return _KEYWORDS[key]
    for k in sorted(_KEYWORDS, key=len, reverse=True):
        if key.startswith(k) and key[len(k)] in " :[(" and not _is_number(key[len(k):].strip(" :")):
            return _KEYWORDS[k]
    return None


def _numbers(line: str, n: int, what: str) -> list[float]:
    values = []
    for token in line.split():
        try:
            v = _number(token)
        except ValueError:
            shown = token if len(token) <= 30 else token[:30] + "…"
            raise reject(f"line {n}: {shown!r} is not a number ({what})", ("file", "line", n)) from None
        values.append(v)
    return values


class _Cut(Exception):
    """The file ends inside a table."""

    def __init__(self, table: str, line: int, got: str):
        super().__init__(table)
        self.table, self.line, self.got = table, line, got


def _read_values(src: _Lines, first: list[float], count: int, name: str, start: int, what: str
                 ) -> tuple[list[float], list[int]]:
    """``count`` values: ``first`` (read from the current record's first line) and the continuation lines after
    it; a continuation line that is blank, a keyword or text ends the table early (refused naming the line)."""
    values, lines = list(first), [src.number() - 1] * len(first)
    while len(values) < count:
        if src.done():
            raise _Cut(name, start, f"{len(values)} of the {count} values of {what}")
        line = src.peek()
        n = src.number()
        if not line.strip() or _keyword(line):
            raise reject(f"line {n}: the {name} table (line {start}) ends after {len(values)} of the {count} values "
                         f"of {what} that its key announces", ("file", "line", n))
        more = _numbers(line, n, f"{name} table, {what}")
        values += more
        lines += [n] * len(more)
        src.i += 1
    if len(values) > count:
        n = lines[count]
        raise reject(f"line {n}: {len(values) - count} value(s) more than the {count} of {what} that the {name} "
                     f"table's key (line {start + 1}) announces; each speed starts a new line", ("file", "line", n))
    return values, lines


def _read_table(src: _Lines, name: str, keyword_line: int) -> Table:
    while not src.done() and not src.peek().strip():  # a blank line between keyword and key is tolerated
        src.i += 1
    if src.done():
        raise _Cut(name, keyword_line, "no key")
    n = src.number()
    head = _numbers(src.peek(), n, f"{name} table key")
    if not head:
        raise reject(f"line {n}: the {name} table has no key", ("file", "line", n))
    key = head[0]
    rows = int(key) if math.isfinite(key) and key > 0 else 0
    cols = round((key - rows) * 1000) if rows else 0
    if rows < 2 or cols < 2 or abs((key - rows) * 1000 - cols) > 1e-6:
        raise reject(f"line {n}: {key:g} is no table key of the {name} table (rows + columns / 1000, e.g. 15.010 for "
                     "14 speeds of 9 beta values)", ("file", "line", n))
    if cols - 1 > MAX_ARGUMENTS or rows - 1 > MAX_ROWS:
        raise reject(f"line {n}: the {name} table's key {key:g} announces {rows - 1} rows of {cols - 1} values; at "
                     f"most {MAX_ROWS} of {MAX_ARGUMENTS} are read (GSP reads {GSP_MAX_PARAMETERS} of {GSP_MAX_ARGUMENTS})", ("file", "line", n))
    src.i += 1
    try:
        return _read_records(src, name, keyword_line, head, n, rows, cols)
    except InputRejected as exc:
        broken = _layout_break(src.lines, name, n, rows, cols, exc)
        if broken is None:
            raise
        raise reject(broken[1] + f"; read on as written, the table goes wrong later: {exc.errors[0].msg}",
                     ("file", "line", broken[0])) from None


def _layout_break(lines: list[str], name: str, key_line: int, rows: int, cols: int, exc: InputRejected
                  ) -> tuple[int, str] | None:
    """The line before the one a table's reading failed at that breaks the layout its key announces: every record
    (the key's, then each speed's) starts a line and is wrapped at one width, so each line holds that many values
    but a record's last. A value lost or added there shifts every later record: the failure surfaces lines later
    (the next speed's first line read as values), at a line that is as it should be."""
    failed = exc.errors[0].loc[-1] if exc.errors and exc.errors[0].loc[:2] == ("file", "line") else None
    if not isinstance(failed, int) or failed <= key_line:
        return None
    counts = [len(line.split()) for line in lines[key_line - 1:failed - 1]]
    if not counts:
        return None
    width = max(set(counts), key=lambda c: (counts.count(c), c))  # most lines of a wrapped table are full
    if width < 2:
        return None
    record = [width] * (cols // width) + ([cols % width] if cols % width else [])
    expected = record * rows
    for k, (got, want) in enumerate(zip(counts, expected)):
        if got != want:
            where = key_line + k
            return where, (f"line {where}: {got} value(s) where the {name} table's layout puts {want} (its key, "
                           f"line {key_line}: {rows - 1} speed rows of {cols - 1} values, {width} a line, each speed "
                           "starting a line): a value " + ("lost" if got < want else "added") + " there?")
    return None


def _read_records(src: _Lines, name: str, keyword_line: int, head: list[float], n: int, rows: int, cols: int
                  ) -> Table:
    """The table after its key's first line: the arguments, then one record per speed."""
    args, arg_lines = _read_values(src, head[1:], cols - 1, name, keyword_line, "arguments")
    _refuse_beyond_bound(args, arg_lines, name, "argument")
    params, values, value_lines, param_lines = [], [], [], []
    for r in range(rows - 1):
        if src.done():
            raise _Cut(name, keyword_line, f"{r} of the {rows - 1} rows")
        line, m = src.peek(), src.number()
        if not line.strip() or _keyword(line):
            raise reject(f"line {m}: the {name} table (line {keyword_line}) ends after {r} of the {rows - 1} rows "
                         f"that its key (line {n}) announces", ("file", "line", m))
        row = _numbers(line, m, f"{name} table")
        src.i += 1
        vals, lines = _read_values(src, row[1:], cols - 1, name, keyword_line, f"row {r + 1}")
        _refuse_beyond_bound(row[:1] + vals, [m] + lines, name, "value")
        params.append(row[0])
        values.append(vals)
        value_lines.append(lines)
        param_lines.append(m)
    if not src.done() and src.peek().strip() and not _keyword(src.peek()) and _is_number(src.peek().split()[0]):
        m = src.number()
        raise reject(f"line {m}: more rows than the {rows - 1} that the {name} table's key (line {n}) announces",
                     ("file", "line", m))
    return Table(name, keyword_line, np.array(args), np.array(params), np.array(values), np.array(value_lines),
                 param_lines)


def _refuse_beyond_bound(values: list[float], lines: list[int], table: str, what: str) -> None:
    """A finite value beyond :data:`MAX_MEASURED` (``1e308`` typed for a missing one, a run-away export) is refused
    naming its line: a map holds nothing that large, and the request could not hold it. NaN and infinities stay
    missing values, which the reader drops with a note."""
    for value, line in zip(values, lines):
        if math.isfinite(value) and abs(value) > MAX_MEASURED:
            where = f"{table!r} line" if what == "setting" else f"the {table} table"
            raise reject(f"line {line}: {what} {value:g} in {where} is beyond {MAX_MEASURED:g}, no value "
                         "of a map (a placeholder for a missing value? Leave the point out, or write NaN)",
                         ("file", "line", line))


def _key_follows(src: _Lines) -> bool:
    """The next non-blank line after the current one starts with a table key (rows + columns / 1000)."""
    for line in src.lines[src.i + 1:src.i + 3]:
        if line.strip():
            try:
                key = _number(line.split()[0])
            except ValueError:
                return False
            return math.isfinite(key) and key >= 2 and abs((key - int(key)) * 1000 - round((key - int(key)) * 1000)) \
                < 1e-6 and round((key - int(key)) * 1000) >= 2
    return False


def _skip_table(src: _Lines, name: str, n: int) -> dict:
    try:
        t = _read_table(src, name, n)
    except _Cut as cut:
        raise reject(f"the file ends inside the {name!r} table (line {cut.line}; {cut.got}): the file was cut?",
                     ("file", "line", cut.line), type="truncated_file") from None
    return {"rows": int(t.values.shape[0]), "columns": int(t.values.shape[1])}


def _not_a_map(text: str) -> InputRejected:
    head = text.lstrip()[:2000]
    if not head:
        hint = "the file holds only blank lines"
    elif "MapData" in head or "np.array(" in head or head.startswith(("import ", "from ")):
        hint = "it is Python text (a pyCycle/NPSS MapData module?): upload it as .py"
    elif head[:1] in "{[":
        hint = "it looks like JSON: upload a JSON request as .json"
    elif "," in head.split("\n", 1)[0] or ";" in head.split("\n", 1)[0] or "\t" in head.split("\n", 1)[0]:
        hint = "it looks like a table with separators (CSV?): upload it as .csv"
    else:
        hint = "a GasTurb/GSP map has a '99 title' line and the tables Mass Flow, Efficiency, Pressure Ratio"
    return reject(f"no GasTurb/GSP compressor map here: none of its tables (Mass Flow, Efficiency, Pressure Ratio) "
                  f"was found; {hint}")


def read_map(text: str) -> tuple[int | None, str, dict, list[TableSet], list[Diagnostic]]:
    """(map type, title, Reynolds data, table sets, notes) of a map file's text; raises :class:`InputRejected`
    naming the line."""
    src = _Lines(text.replace("\x1a", ""))
    notes: list[Diagnostic] = []
    map_type, title, reynolds = None, "", {}
    sets: list[TableSet] = [TableSet()]
    seen_header = False
    ignored: list[dict] = []  # tables of other names: read (so that a garbled one is refused) and left out
    while not src.done():
        line, n = src.peek(), src.number()
        stripped = line.strip()
        if not stripped:
            src.i += 1
            continue
        tokens = stripped.split()
        if not seen_header and stripped.startswith(("#", "!", "//")):
            src.i += 1  # a comment some tools put above the map type line
            continue
        if not seen_header:
            seen_header = True
            if re.fullmatch(r"[+-]?\d+", tokens[0]):
                map_type, title = int(tokens[0]), stripped[len(tokens[0]):].strip()
                src.i += 1
                continue
            if not _keyword(stripped) and not stripped.lower().startswith("reynolds"):
                if not any(_keyword(ln) for ln in src.lines):
                    raise _not_a_map(text)
                raise reject(f"line {n}: {stripped[:60]!r} is not a map type indicator and title (e.g. '99 title')",
                             ("file", "line", n))
        if stripped.lower().startswith("reynolds"):
            pairs = _REYNOLDS.findall(stripped)
            try:
                reynolds = {"RNI": [_number(a) for a, _ in pairs], "f": [_number(b) for _, b in pairs], "line": n}
            except ValueError:
                pairs = []
            if not pairs:
                raise reject(f"line {n}: the Reynolds line is not 'Reynolds: RNI=x1 f=y1 RNI=x2 f=y2'",
                             ("file", "line", n))
            src.i += 1
            continue
        name = _keyword(stripped)
        if name in TURBINE_TABLES:
            raise reject(f"this is a turbine map (its '{name}' table, line {n}): perfmap reads compressor and fan maps "
                         "(Mass Flow, Efficiency, Pressure Ratio over beta and speed; Surge Line), whose pressure falls "
                         "with flow", ("file", "line", n))
        if name is None and (setting := _SETTING_LINE.match(stripped)):
            label, value, unit = setting.group(1).strip(), _number(setting.group(2)), (setting.group(3) or "").strip()
            _refuse_beyond_bound([value], [n], label, "setting")
            current = sets[-1]
            if current.tables or current.setting is not None:
                if current.setting is None:
                    raise reject(f"line {n}: a geometry setting ({label} = {value:g}) after tables that had none: "
                                 "each set of tables needs its setting line", ("file", "line", n))
                sets.append(TableSet())
            sets[-1].setting, sets[-1].label, sets[-1].unit, sets[-1].line = value, label, unit, n
            src.i += 1
            continue
        if name is None:
            if not _is_number(tokens[0]) and _key_follows(src):
                src.i += 1  # a table a compressor map does not have (GasTurb writes some for its own use)
                ignored.append({"table": stripped[:60], "line": n, **_skip_table(src, stripped, n)})
                continue
            raise reject(f"line {n}: {stripped[:60]!r} is neither a table keyword of a compressor map "
                         f"({', '.join(SPEED_TABLES + LIMIT_TABLES)}) nor part of a table", ("file", "line", n))
        src.i += 1
        current = sets[-1]
        if name in current.tables:
            raise reject(f"line {n}: a second {name} table (the first is at line {current.tables[name].line}); a map "
                         "with variable geometry names the setting of each set of tables on a line before it "
                         "('VG angle = -5')", ("file", "line", n))
        try:
            table = _read_table(src, name, n)
            if name in LIMIT_TABLES and table.values.shape[0] != 1:
                raise reject(f"line {n + 1}: the {name} table's key announces {table.values.shape[0]} rows of "
                             "pressure ratios; a limit line is a 2-row table (2.CCC: the flows, then one row)",
                             ("file", "line", n + 1))
            table.heading = stripped
            current.tables[name] = table
        except _Cut as cut:
            if name in LIMIT_TABLES and all(t in current.tables for t in SPEED_TABLES):
                notes.append(truncated_file(cut.line, f"the {name} table is cut ({cut.got} read): it was left out.",
                                            table=name))
                break
            raise reject(f"the file ends inside the {name} table (line {cut.line}; {cut.got}): the file was cut? "
                         "The map needs every speed table whole.", ("file", "line", cut.line),
                         type="truncated_file") from None
        continue
    if ignored:
        notes.append(Diagnostic(code="upload_tables_ignored", message=(
            f"Table(s) a compressor map does not need, read and left out: "
            f"{', '.join(repr(t['table']) + ' (line ' + str(t['line']) + ')' for t in ignored)}."),
            details={"tables": ignored}))
    if not any(s.tables for s in sets):
        raise _not_a_map(text)
    return map_type, title, reynolds, sets, notes


def _distinct_flows(flow: np.ndarray) -> int:
    """Distinct flows of a speed line as the solver counts them: flows at the top within its choke tolerance are
    one (a vertical choke segment)."""
    if flow.size == 0:
        return 0
    x = np.sort(flow)
    top = x >= x[-1] - CHOKE_FLOW_TOLERANCE * (x[-1] - x[0])
    return int(np.unique(x[~top]).size) + 1


def _match_rows(t: Table, flow: Table) -> Diagnostic | None:
    """Rows of ``t`` put in the Mass Flow table's speed order when they hold the same speeds in another order (a
    table written or pasted in another order: each row is keyed by its speed, so the right row is known)."""
    if t.params.shape != flow.params.shape or np.allclose(t.params, flow.params, rtol=1e-6, atol=1e-9):
        return None
    order, wanted = np.argsort(t.params, kind="stable"), np.argsort(flow.params, kind="stable")
    if not np.allclose(t.params[order], flow.params[wanted], rtol=1e-6, atol=1e-9):
        return None
    perm = np.empty_like(order)
    perm[wanted] = order  # row perm[i] of t has the speed of the Mass Flow table's row i
    t.params, t.values, t.value_lines = t.params[perm], t.values[perm], t.value_lines[perm]
    t.param_lines = [t.param_lines[i] for i in perm]
    return Diagnostic(code="upload_rows_reordered", message=(
        f"The {t.name} table (line {t.line}) lists the speeds of the Mass Flow table (line {flow.line}) in another "
        "order: its rows were matched to them by speed."), details={"table": t.name, "line": t.line,
                                                                    "speeds": [float(v) for v in t.params]})


def _limit_line_off_map(s: TableSet) -> list[Diagnostic]:
    """A Surge or Choke Line whose points lie outside the flows or pressure ratios of the speed tables by more
    than a tenth of their range: its values contradict the tables (another map, another flow unit?). Kept as a
    note, since the result's limit lines are the fitted speed lines' own ends."""
    out = []
    W, P = s.tables["Mass Flow"].values, s.tables["Pressure Ratio"].values
    ok = np.isfinite(W) & np.isfinite(P)
    if not ok.any():
        return out
    for name in LIMIT_TABLES:
        if name not in s.tables:
            continue
        t = s.tables[name]
        for quantity, values, table in (("flow", t.args, W[ok]), ("pressure ratio", t.values[0], P[ok])):
            lo, hi = float(table.min()), float(table.max())
            margin = 0.1 * (hi - lo)
            off = np.flatnonzero((values < lo - margin) | (values > hi + margin))
            if off.size:
                k = int(off[0])
                out.append(Diagnostic(code="upload_limit_line_off_map", message=(
                    f"The {name} table (line {t.line}): {off.size} of its {len(values)} points have a {quantity} "
                    f"outside the speed tables' {lo:g} to {hi:g} (first: {values[k]:g}); another map or another "
                    f"unit? The result's {name.lower()} is the fitted speed lines' own ends."),
                    details={"table": name, "line": t.line, "quantity": quantity, "values": values[off].tolist()[:100],
                             "range": [lo, hi]}))
    return out


def _misspelt(missing: list[str], ignored: list[dict]) -> list[tuple[int, str]]:
    """(line, clause) of each table read as one a compressor map does not need whose heading is a missing table's
    keyword misspelt ('Efficency', 'Massflow', 'Press. Ratio'). Without it the refusal said only that the table was
    missing, while a user looking at the file saw it there."""
    def key(text: str) -> str:
        return re.sub(r"[^a-z]", "", re.sub(r"[\[(].*", "", text.lower()))
    found = []
    for name in missing:
        close = [t for t in ignored if difflib.SequenceMatcher(None, key(t["table"]), key(name)).ratio() >= 0.75]
        found += [(t["line"], (f"line {t['line']} heads a table {t['table'].strip()!r}: the {name} keyword "
                               "misspelt? (read as a table a compressor map does not need)")) for t in close[:1]]
    return found


def _check_set(s: TableSet, cut_line: int | None, ignored: list[dict] = ()) -> list[Diagnostic]:
    missing = [t for t in SPEED_TABLES if t not in s.tables]
    where = f" of the set at line {s.line} ({s.label} = {s.setting:g})" if s.setting is not None else ""
    if missing and (misspelt := _misspelt(missing, list(ignored))):
        raise reject(f"no {' and no '.join(missing)} table{where}; " + "; ".join(c for _, c in misspelt),
                     ("file", "line", misspelt[0][0]))
    if missing:
        # the last tables missing and nothing after them: the file stops where they would begin
        present = [t for t in SPEED_TABLES if t in s.tables]
        trailing = SPEED_TABLES[len(present):] == tuple(missing) and not any(t in s.tables for t in LIMIT_TABLES)
        cut = trailing or cut_line is not None
        raise reject(f"no {' and no '.join(missing)} table{where}"
                     f"{' (the file ends before it: cut?)' if trailing and present else ''}: a compressor map needs "
                     "Mass Flow, Efficiency and Pressure Ratio over the same speeds and beta values",
                     ("file", missing[0]), type="truncated_file" if cut else "value_error")
    flow = s.tables["Mass Flow"]
    dup = np.flatnonzero(np.diff(np.sort(flow.params)) == 0)
    if dup.size:
        v = np.sort(flow.params)[dup[0]]
        lines = [ln for p, ln in zip(flow.params, flow.param_lines) if p == v]
        raise reject(f"line {lines[-1]}: speed {v:g} appears twice in the Mass Flow table (lines {lines[0]} and "
                     f"{lines[-1]})", ("file", "line", lines[-1]))
    notes = []
    for name in SPEED_TABLES[1:]:
        t = s.tables[name]
        if (reordered := _match_rows(t, flow)) is not None:
            notes.append(reordered)
        if t.values.shape != flow.values.shape:
            raise reject(f"line {t.line}: the {name} table has {t.values.shape[0]} speeds of {t.values.shape[1]} beta "
                         f"values, the Mass Flow table (line {flow.line}) {flow.values.shape[0]} of "
                         f"{flow.values.shape[1]}", ("file", "line", t.line))
        for what, a, b, lines in (("speeds", t.params, flow.params, t.param_lines),
                                  ("beta values", t.args, flow.args, [t.line + 1] * len(t.args))):
            bad = np.flatnonzero(~np.isclose(a, b, rtol=1e-6, atol=1e-9))
            if bad.size:
                k = int(bad[0])
                raise reject(f"line {lines[k]}: the {name} table's {what} differ from the Mass Flow table's "
                             f"({a[k]:g} where line {flow.line} has {b[k]:g})", ("file", "line", lines[k]))
    eff = s.tables["Efficiency"]
    over = np.argwhere(np.isfinite(eff.values) & (eff.values > 1.0))
    if over.size:
        r, c = over[0]
        n = int(eff.value_lines[r, c])
        percent = bool(np.nanmax(eff.values) <= 100.0 and np.nanmedian(eff.values) > 1.0)
        raise InputRejected(FieldError(("file", "row", n, "efficiency"), (
            f"line {n}: efficiency {eff.values[r, c]:g} at speed {eff.params[r]:g} is above 1"
            + ("; the table looks like percent: GasTurb and GSP maps hold fractions (0.86)" if percent else
               "; map efficiencies are fractions (0.86)"))))
    return notes + _limit_line_off_map(s)


def _same_unit(a, b) -> bool:
    """Two spellings of one unit (lb/s and lbm/s)."""
    try:
        return abs(a.factor_to(b) - 1.0) < 1e-12
    except pint.errors.DimensionalityError:  # a mass flow against a volume flow
        return False


def _title_speed_unit(title: str) -> str | None:
    """The speed unit a title states ('speed [rpm]', as this service's export writes a map fitted in rpm or per
    cent) when it is a shaft speed's or a per cent's, else None. A title is free text (GasTurb's own maps name their
    speed as they like, 'speed [N/Nd]'): what is no such unit is left to the speeds' values, not refused."""
    m = _TITLE_SPEED.search(title)
    if m is None:
        return None
    text = m.group(1).strip()
    try:
        unit = parse_speed_unit(text)
    except UnitError:
        return None
    rotational = not unit.dimensionless and revolutions_per_minute(unit.unit) is not None
    return text if rotational or unit.text in ("%", "‰") else None


def _flow_unit(options: dict, title: str, heading: str) -> tuple[dict, str | None]:
    """(units, where the flow unit came from): the upload's units option, else a unit in brackets on the Mass Flow
    table's line ('Mass Flow [kg/s]'), else a 'flow [unit]' in the title."""
    given = options.get("units")
    if given is not None and not isinstance(given, dict):
        raise reject("options.units must be an object such as {\"flow\": \"kg/s\"}", ("options", "units"))
    units = {"pressure": "1", "efficiency": "1"}
    source = None
    for quantity, unit in _TITLE_UNIT.findall(title):
        unit = unit.strip()
        if unit.lower() not in ("unit not stated",):
            unit = "1" if unit in ("-", "1") else unit
            try:
                check_quantity(quantity.lower(), unit)
            except UnitError as e:
                raise reject(f"the title's {quantity} unit: {e}", ("file", "title")) from None
            units[quantity.lower()] = unit
            source = "title"
    if (m := re.search(r"\[([^\]]+)\]", heading)) is not None:
        try:
            parsed = check_quantity("flow", m.group(1))
        except UnitError as e:
            raise reject(f"the Mass Flow table's unit: {e}", ("file", "Mass Flow")) from None
        titled = units.get("flow") if source == "title" else None
        if titled is not None and not _same_unit(check_quantity("flow", titled), parsed):
            # the file states two units for one table: taking either would be a guess, 2.2 times off for kg/s and lb/s
            raise reject(f"the Mass Flow table's line says {m.group(1).strip()!r} but the title says flow "
                         f"[{titled}]: which is meant? State the unit once", ("file", "Mass Flow"))
        units["flow"], source = m.group(1).strip(), "Mass Flow table's line"
    for quantity, unit in (given or {}).items():
        if quantity not in ("flow", "pressure", "efficiency"):
            raise reject(f"options.units.{quantity}: a map's units are flow, pressure and efficiency",
                         ("options", "units", quantity))
        if not isinstance(unit, str):
            raise reject(f"options.units.{quantity} must be a unit text such as 'kg/s'", ("options", "units", quantity))
        try:
            parsed = check_quantity(quantity, unit)
        except UnitError as e:
            raise reject(f"options.units.{quantity}: {e}", ("options", "units", quantity)) from None
        if quantity == "pressure" and parsed.text != "1":
            # the table is GasTurb's Pressure Ratio: a pressure unit would label ratios as pressures
            raise reject(f"options.units.pressure {unit!r}: a map's Pressure Ratio table holds ratios (p2/p1, "
                         "dimensionless); leave units.pressure out, or give '-'", ("options", "units", "pressure"))
        stated = units.get(quantity) if quantity == "flow" and source is not None else None
        if stated is not None and not _same_unit(check_quantity("flow", stated), parsed):
            raise reject(f"options.units.flow {unit!r} contradicts the file, whose {source} states {stated!r}: say "
                         "which is right (leave the option out to use the file's, or correct the file)",
                         ("options", "units", "flow"))
        units[quantity] = unit
        source = "options.units" if quantity == "flow" else source
    return units, source if "flow" in units else None


def request_body(content: bytes, options: dict | None) -> tuple[dict, list[int], dict | None]:
    """(request body, file line of each position's speed line in the Mass Flow table, the options left for the
    request) of an uploaded map file; the upload's ``units`` option states the file's units (a map states none)."""
    text = decode_text(content, "GasTurb/GSP map text file")
    options = dict(options or {})
    map_type, title, reynolds, sets, notes = read_map(text)
    cut = next((d.details.get("line") for d in notes if d.code == "truncated_file"), None)
    ignored = [t for d in notes if d.code == "upload_tables_ignored" for t in d.details["tables"]]
    for s in sets:
        notes.extend(_check_set(s, cut, ignored))
    if len(sets) == 1 and sets[0].setting is not None:  # one geometry: its setting is a note, not a parameter
        only = sets[0]
        notes.append(Diagnostic(code="upload_geometry_setting", message=(
            f"One set of tables, at {only.label} = {only.setting:g}{' ' + only.unit if only.unit else ''} (line "
            f"{only.line}): read as a map of speed alone."), details={"label": only.label, "value": only.setting,
                                                                       "unit": only.unit, "line": only.line}))
        sets = [TableSet(tables=only.tables)]
    if any(s.setting is not None for s in sets):
        labels = {s.label.lower() for s in sets}
        if len(labels) > 1 or any(s.setting is None for s in sets):
            s = next(s for s in sets if s.setting is None or s.label.lower() != sets[0].label.lower())
            n = s.line or next(iter(s.tables.values())).line
            raise reject(f"line {n}: every set of tables needs a setting line with the same name as the first "
                         f"({sets[0].label!r}, line {sets[0].line})", ("file", "line", n))
        values = [s.setting for s in sets]
        if len(set(values)) < len(values):
            s = next(s for i, s in enumerate(sets) if s.setting in values[:i])
            raise reject(f"line {s.line}: {s.label} = {s.setting:g} appears twice", ("file", "line", s.line))
        if named_as_speed(sets[0].label):
            # its settings and the speeds of its rows would be two parameters of one name (it crashed the reader)
            raise reject(f"line {sets[0].line}: the setting line names {sets[0].label!r}, a name of the map's speed: a "
                         "set of tables is headed by its geometry setting ('VG angle = -5 [deg]'); the speeds are "
                         "each table's rows", ("file", "line", sets[0].line))
    units, unit_source = _flow_unit(options, title, sets[0].tables["Mass Flow"].heading)
    options.pop("units", None)
    positions, lines = [], []
    dropped, short, dropped_at = 0, [], []
    for s in sets:
        W, E, P = (s.tables[t] for t in SPEED_TABLES)
        for r, speed in enumerate(W.params):
            w, e, p = W.values[r], E.values[r], P.values[r]
            ok = np.isfinite(w) & np.isfinite(e) & np.isfinite(p) & (w > 0) & (p > 0) & (e > 0)
            dropped += int(np.sum(~ok))
            for j in np.flatnonzero(~ok)[:max(0, MAX_DROPPED_NAMED - len(dropped_at))]:
                # the first table whose value is not a positive finite number: where the file has to be mended
                name, table = next((n, t) for n, t in zip(SPEED_TABLES, (W, E, P))
                                   if not (np.isfinite(t.values[r][j]) and t.values[r][j] > 0))
                dropped_at.append({"table": name, "line": int(table.value_lines[r][j]), "speed": float(speed),
                                   "beta": float(W.args[j]), "value": str(table.values[r][j])})
            setting = [float(speed)] if s.setting is None else [float(s.setting), float(speed)]
            distinct = _distinct_flows(w[ok])
            if distinct < 3:  # GasTurb's sample maps end in fully choked lines: one flow at every beta
                short.append({"setting": setting, "points": int(ok.sum()), "distinct_flows": distinct,
                              "line": W.param_lines[r]})
                continue
            positions.append({"setting": setting, "flow": w[ok].tolist(), "pressure": p[ok].tolist(),
                              "efficiency": e[ok].tolist()})
            lines.append(int(W.param_lines[r]))
    if not positions:
        raise reject("no speed line of the map has 3 usable points (positive flow, pressure ratio and efficiency)",
                     ("file", "Mass Flow"))
    vg = sets[0].setting is not None
    top_speed = max(p["setting"][-1] for p in positions)
    relative = top_speed <= MAX_RELATIVE_SPEED
    titled = _title_speed_unit(title)
    untaken = titled if titled is not None and relative else None
    if untaken is not None:  # speeds up to 3 in rpm or per cent are no compressor's: the title's unit is wrong
        titled = None
    speed_unit = titled or ("1" if relative else "")
    names = [sets[0].label, "Nc"] if vg else ["Nc"]
    setting_units = [sets[0].unit, speed_unit] if vg else [speed_unit]
    if not relative and titled is None:
        notes.append(Diagnostic(code="implausible_speed", message=(
            f"Speed {top_speed:g} in a GasTurb/GSP map: plausible relative corrected speeds are 0 to "
            f"{MAX_RELATIVE_SPEED:g} (GasTurb writes N/sqrt(T) over its reference value, e.g. 0.45 to 1.1); percent or "
            "rpm read as relative speed? The speeds are kept as written, without a unit."),
            details={"value": top_speed, "range": [0.0, MAX_RELATIVE_SPEED]}))
    flow = sets[0].tables["Mass Flow"]
    flow_unit = units.get("flow")
    limits = {}
    for s in sets:
        for t in LIMIT_TABLES:
            if t in s.tables:
                lt = s.tables[t]
                limits.setdefault(t, []).append({"setting": s.setting, "line": lt.line, "flow": lt.args.tolist(),
                                                 "pressure": lt.values[0].tolist()})
    what = (f"GasTurb/GSP compressor map (type {map_type if map_type is not None else 'not stated'}"
            f"{', ' + repr(title) if title else ''}): {len(positions)} speed lines of {len(flow.args)} beta points"
            f"{f' at {len(sets)} values of {sets[0].label}' if vg else ''}. Speed: "
            + (f"in {titled}, as the title states" if titled else
               "relative corrected speed N/sqrt(T) over its map reference (dimensionless)"
               + (f", not in the title's {untaken} (speeds up to {top_speed:g})" if untaken else ""))
            + "; flow: corrected mass flow W sqrt(T)/P "
            f"({'in ' + flow_unit + ', from the ' + unit_source if flow_unit else 'the file states no unit: GasTurb writes kg/s in SI, lb/s in imperial units; give it with the units option'}); "
            "pressure ratio; efficiency a fraction.")
    notes.insert(0, Diagnostic(code="upload_settings", message=what, details={
        "format": "gasturb", "map_type": map_type, "title": title, "names": names, "units": setting_units,
        "speed": f"in {titled} (the title)" if titled else "relative corrected speed (N/sqrt(T)) / (N/sqrt(T))_ref, "
                 "dimensionless" + (f" (the title's {untaken} not taken)" if untaken else ""),
        "flow": f"corrected mass flow W sqrt(T)/P [{flow_unit or 'unit not stated'}]", "flow_unit_from": unit_source,
        "beta": [float(b) for b in flow.args], "reynolds": reynolds,
        "surge_line": limits.get("Surge Line"), "choke_line": limits.get("Choke Line")}))
    notes.append(Diagnostic(code="upload_rline_not_needed", message=(
        f"Beta values {', '.join(f'{b:g}' for b in flow.args[:6])}{', …' if len(flow.args) > 6 else ''} recognised "
        "and not needed: each beta point is a measured point, each line is parametrised by its flow."),
        details={"beta": [float(b) for b in flow.args]}))
    if reynolds and any(f != 1.0 for f in reynolds["f"]):
        notes.append(Diagnostic(code="upload_reynolds_correction", message=(
            f"The map's Reynolds correction (line {reynolds['line']}: " + ", ".join(
                f"RNI {a:g} -> f {b:g}" for a, b in zip(reynolds["RNI"], reynolds["f"]))
            + ") belongs to the cycle code: the tables are read as they stand, the map at its reference Reynolds "
            "number."), details=reynolds))
    if "Surge Line" not in limits:
        notes.append(Diagnostic(code="upload_no_surge_line", message=(
            "The map has no Surge Line table (GasTurb and GSP read one with every compressor map; the file was cut?): "
            "the result's surge line is the speed lines' surge ends."), details={}))
    if dropped or short:
        lines_out = ", ".join(f"{d['setting'][-1]:g} (line {d['line']}, {d['distinct_flows']} distinct flows)"
                              for d in short[:10])
        points_at = "; ".join(f"{d['table']} line {d['line']} (speed {d['speed']:g}, beta {d['beta']:g}: "
                              f"{d['value']})" for d in dropped_at[:5]) + ("; …" if dropped > 5 else "")
        notes.append(Diagnostic(code="upload_points_dropped", message=(
            f"{dropped} map point(s) without positive finite values dropped{': ' + points_at if dropped else ''}; "
            f"{len(short)} speed line(s) with fewer than 3 distinct flows (choked: vertical in the map) left out"
            f"{': speed ' + lines_out if short else ''}."),
            details={"points": dropped, "at": dropped_at, "lines": short[:100]}))
    body = {"positions": positions, "setting_names": names, "setting_units": setting_units, "units": units,
            "upload_warnings": [d.model_dump() for d in notes]}
    return body, lines, options or None
