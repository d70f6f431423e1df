"""Stickers: parts drawn flat on another part's face, carrying no joint and no load.

An LDraw sticker is a part of category ``Sticker`` (its ``0 !CATEGORY`` line or, without one, the first word of its
title after LDraw's marks). It has no snap information, so it is not in the catalogue; counted as an unknown part it
would make a model of a few bricks and as many stickers NOT DETERMINED though nothing of it is unknown. The solver
leaves stickers out of the analysis and names them instead: the official ones from the list the catalogue generator
writes from the LDraw library (``data/ldraw_stickers.txt.gz``, ``scripts/ldcad_catalogue.py --stickers``), and those a
model defines itself (an embedded ``0 FILE`` part whose header says so, read by the upload reader).
"""

from __future__ import annotations

import functools
import gzip
from collections.abc import Iterable
from pathlib import Path

DATA = Path(__file__).with_name("data") / "ldraw_stickers.txt.gz"
MARKS = "~_|="  # LDraw's title marks: moved or alias (~, =), physical colour (_), not a part to place (|)
STICKER = "Sticker"  # the category; "Sticker Shortcut" (a part with its sticker applied) has its own snaps


def category(lines: Iterable[str]) -> str:
    """A part file's LDraw category: its ``0 !CATEGORY`` line, else the first word of its title (its first
    comment line) after the marks."""
    title = None
    for raw in lines:
        tokens = raw.split(None, 2)
        if len(tokens) == 3 and tokens[0] == "0" and tokens[1] == "!CATEGORY":
            return tokens[2].strip()
        if title is None and tokens[:1] == ["0"]:
            title = raw.split(None, 1)[1] if len(tokens) > 1 else ""
    words = (title or "").lstrip().lstrip(MARKS).split()
    return words[0] if words else ""


@functools.lru_cache(maxsize=1)
def official_stickers() -> frozenset[str]:
    """The numbers of the LDraw library's stickers (lower case, without ``.dat``)."""
    with gzip.open(DATA, "rt", encoding="utf-8") as handle:
        next(handle)  # the header: which library
        return frozenset(line.strip() for line in handle if line.strip())


def is_sticker(number: str, defined: Iterable[str] = ()) -> bool:
    """Whether a part number (normalised: lower case, no ``.dat``) is an official sticker or one of ``defined``,
    the stickers the model defines itself."""
    return number in official_stickers() or number in set(defined)
