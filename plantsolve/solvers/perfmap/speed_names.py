"""The names rigs and cycle codes give a corrected speed: the map's readers, its checks and its exports tell the
speed among the settings by them."""

from __future__ import annotations

import re

SPEED_NAMES = {"speed", "corrected speed", "nc", "n c", "nc map", "ncmap", "relative speed", "rel speed", "rpm",
               "n", "shaft speed", "rotational speed", "corrected rotational speed", "nmech", "pcn", "% speed",
               "percent speed", "n/sqrt(theta)", "n/√θ", "speed line"}


def named_as_speed(name: str) -> bool:
    """Whether a setting's name (its unit in brackets dropped) is one rigs and cycle codes give a speed; a name
    whose brackets are its own ('N/sqrt(theta)') is one as written."""
    return any(re.sub(r"[\s_\-]+", " ", n.strip().lower()) in SPEED_NAMES
               for n in (name, re.sub(r"\s*[\[(].*$", "", name)))
