"""Repeated readings of one setting at one flow that disagree: they are averaged into one point, but repeat runs of
one rig agree within a per cent or two; a spread beyond REPEAT_DISAGREEMENT is two runs (two rigs, two days, a
swapped column) mixed in one line, and an average of them is neither. The warning names the spread and the points'
lines so that the user sees it, instead of a quiet average."""

from __future__ import annotations

from plantsolve.schemas.common import Diagnostic
from plantsolve.solvers.perfmap.setting_lines import Repeat, Setting
from plantsolve.solvers.perfmap.speed_names import named_as_speed

REPEAT_DISAGREEMENT = 0.05  # (max - min) / mean of the pressures or the efficiencies at one flow
MAX_NAMED = 10


def _where(setting: Setting, repeat: Repeat, rows_of: list[list[int]] | None, row_label: str) -> str:
    if rows_of and setting.source_index < len(rows_of):
        rows = rows_of[setting.source_index]
        return f"{row_label}s {', '.join(str(rows[k]) for k in repeat.points if k < len(rows))}"
    return f"points {', '.join(map(str, repeat.points))} of positions[{setting.source_index}]"


def disagreeing_repeats(settings: list[Setting], rows_of: list[list[int]] | None = None,
                        row_label: str = "line") -> list[Diagnostic]:
    """One ``repeated_points_disagree`` warning naming every averaged group whose pressures or efficiencies spread
    more than REPEAT_DISAGREEMENT (``rows_of[i][k]``: the file row of point k of position i, for an upload)."""
    found = [(s, r) for s in settings for r in s.repeats
             if max(r.pressure_spread, r.efficiency_spread) > REPEAT_DISAGREEMENT]
    if not found:
        return []
    named = "; ".join(
        f"setting {s.label}, flow {r.flow:g} ({_where(s, r, rows_of, row_label)}): pressures "
        f"{', '.join(f'{v:.4g}' for v in r.pressures)} ({r.pressure_spread:.1%} apart), efficiencies "
        f"{', '.join(f'{v:.4g}' for v in r.efficiencies)} ({r.efficiency_spread:.1%} apart)"
        for s, r in found[:MAX_NAMED])
    groups = [{"setting": list(s.values), "position": s.source_index, "flow": r.flow, "points": list(r.points),
               "lines": [rows_of[s.source_index][k] for k in r.points] if rows_of else None,
               "pressures": list(r.pressures), "efficiencies": list(r.efficiencies),
               "pressure_spread": r.pressure_spread, "efficiency_spread": r.efficiency_spread} for s, r in found[:100]]
    return [Diagnostic(
        code="repeated_points_disagree",
        message=f"{len(found)} group(s) of readings at one setting and flow disagree by more than "
        f"{REPEAT_DISAGREEMENT:.0%} and were averaged: {named}{' …' if len(found) > MAX_NAMED else ''}. Repeat runs "
        "of one rig agree closer: two runs (two rigs, two days?) mixed in one line, or a value mistyped? The average "
        "is neither run; keep one run per line.",
        details={"count": len(found), "threshold": REPEAT_DISAGREEMENT, "groups": groups})]


def _speed_index(names: tuple[str, ...]) -> int | None:
    """The setting named as a speed, or None."""
    return next((k for k, n in enumerate(names) if named_as_speed(n)), None)


def _whole_planes(pairs: list[tuple[Setting, Setting]], settings: list[Setting], k: int) -> set[tuple[float, float]]:
    """The values (a, b) of setting k where every line at a (two or more) has its twin at b: a whole plane of
    another setting repeated, as pyCycle repeats its table at a second alpha, when setting k may be that one."""
    lines_at: dict[float, int] = {}
    for s in settings:
        lines_at[s.values[k]] = lines_at.get(s.values[k], 0) + 1
    twins: dict[tuple[float, float], int] = {}
    for a, b in pairs:
        twins[a.values[k], b.values[k]] = twins.get((a.values[k], b.values[k]), 0) + 1
    return {ab for ab, n in twins.items() if n == lines_at[ab[0]] >= 2}


def _key(s: Setting, speed: int) -> bytes:
    """The geometry (every setting but the speed) and the measured points of a line."""
    geometry = s.values[:speed] + s.values[speed + 1:]
    return repr(geometry).encode() + b"".join(v.tobytes() for v in (s.x, s.y, s.eta))


def identical_lines(settings: list[Setting], rows_of: list[list[int]] | None = None,
                    row_label: str = "line", heads: list[int] | None = None) -> list[Diagnostic]:
    """One ``setting_lines_identical`` warning naming two lines of one geometry (settings alike but the speed)
    whose measured points are the same points, flow, pressure and efficiency alike: a rig measures two speeds to two
    lines, so one line pasted a second time under the next speed is what that is, and the map was built with the
    true line lost. Identical planes of a geometry setting are no mistake: pyCycle's maps without variable geometry
    repeat their table at a second alpha, so a pair is named once however many planes repeat it, and where no setting
    is named as the speed (the last is taken for it) a whole plane repeated at another value of it is no pair
    (``heads[i]``: the file line heading position i, a map file's speed line)."""
    if not settings:
        return []
    named = _speed_index(settings[0].names)
    speed = len(settings[0].names) - 1 if named is None else named
    seen: dict[bytes, Setting] = {}
    pairs, tables = [], set()
    for s in settings:
        key = _key(s, speed)
        if key not in seen:
            seen[key] = s
            continue
        table = b"".join(v.tobytes() for v in (s.x, s.y, s.eta))
        if table not in tables:  # the same pair in a repeated geometry plane is one mistake
            tables.add(table)
            pairs.append((seen[key], s))

    if named is None and len(settings[0].names) > 1:
        planes = _whole_planes(pairs, settings, speed)
        pairs = [(a, b) for a, b in pairs if (a.values[speed], b.values[speed]) not in planes]

    def where(s: Setting) -> str:
        if rows_of and s.source_index < len(rows_of):
            rows = rows_of[s.source_index]
            return f"{row_label}s {rows[0]}..{rows[-1]}"
        if heads and s.source_index < len(heads):
            return f"line {heads[s.source_index]}"
        return f"positions[{s.source_index}]"

    if not pairs:
        return []
    listed = "; ".join(f"{a.label} ({where(a)}) and {b.label} ({where(b)})" for a, b in pairs[:MAX_NAMED])
    return [Diagnostic(
        code="setting_lines_identical",
        message=f"{len(pairs)} pair(s) of settings hold the same {len(pairs[0][0].x)} measured points, flow, "
        f"pressure and efficiency alike: {listed}{' …' if len(pairs) > MAX_NAMED else ''}. Two settings measure two "
        "lines: one line pasted a second time under another setting's value? The map is built as given.",
        details={"pairs": [{"settings": [list(a.values), list(b.values)],
                            "positions": [a.source_index, b.source_index]} for a, b in pairs[:100]]})]
