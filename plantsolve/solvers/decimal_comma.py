"""A number as a decimal-comma locale writes it (``3,25``, ``-0,5e-3``): formats whose numbers take a decimal point
(STL, OBJ) name such a word when they refuse or skip its line, rather than saying only 'not a number'."""

from __future__ import annotations

import re

DECIMAL_COMMA = re.compile(r"[-+]?\d*,\d+(?:[eE][-+]?\d+)?")


def is_decimal_comma(word: str) -> bool:
    return DECIMAL_COMMA.fullmatch(word) is not None
