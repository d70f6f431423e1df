"""The perfflow58 review's findings on perfmap: identical setting lines told by the setting named as the speed (not
the last) and named at the file's lines, and a refusal of a JSON body or upload named where the value was written."""

from __future__ import annotations

from pathlib import Path

from plantsolve.schemas.perfmap import PerfmapRequest
from plantsolve.solvers.perfmap.validation import load

EXAMPLES = Path(__file__).resolve().parents[3] / "examples" / "perfmap"
ROWS = [r.split(",") for r in (EXAMPLES / "n3_fan_map.csv").read_text().splitlines()[1:] if r.startswith("0.0,")]
SPEEDS = sorted({r[1] for r in ROWS})


def _line(speed: str) -> dict:
    rows = [r for r in ROWS if r[1] == speed]
    return {k: [float(r[c]) for r in rows] for k, c in (("flow", 2), ("pressure", 3), ("efficiency", 4))}


def _speed_alpha_body(measured_at: dict[tuple[str, float], str] | None = None) -> dict:
    """Speed lines at alpha 0 and 1 with the same tables, pyCycle-style, speed first; ``measured_at`` pastes the
    line of another speed at (speed, alpha)."""
    positions = [{"setting": [float(v), alpha], **_line((measured_at or {}).get((v, alpha), v))}
                 for alpha in (0.0, 1.0) for v in SPEEDS]
    return {"setting_names": ["speed", "alpha"], "positions": positions, "options": {"map": False}}


def _identical(body: dict):
    return [w for w in load(PerfmapRequest.model_validate(body)).warnings if w.code == "setting_lines_identical"]


def test_repeated_alpha_planes_with_the_speed_named_first_are_not_warned():
    assert len(SPEEDS) >= 3
    assert _identical(_speed_alpha_body()) == []


def test_a_line_pasted_under_the_next_speed_is_warned_with_the_speed_named_first():
    (warning,) = _identical(_speed_alpha_body({(SPEEDS[2], 1.0): SPEEDS[1]}))
    assert warning.details["pairs"] == [{"settings": [[float(SPEEDS[1]), 1.0], [float(SPEEDS[2]), 1.0]],
                                         "positions": [len(SPEEDS) + 1, len(SPEEDS) + 2]}]


def test_a_pasted_line_repeated_in_every_alpha_plane_is_one_pair():
    pasted = {(SPEEDS[2], alpha): SPEEDS[1] for alpha in (0.0, 1.0)}
    (warning,) = _identical(_speed_alpha_body(pasted))
    assert [p["settings"] for p in warning.details["pairs"]] == [[[float(SPEEDS[1]), 0.0], [float(SPEEDS[2]), 0.0]]]
