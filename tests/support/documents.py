"""A JSON document with one value set at a path (keys and list indices), the rest a deep copy: the probes' and tests'
way of making the one mistake a case is about in an otherwise valid example."""

from __future__ import annotations

import copy
from typing import Any


def with_value(document: Any, path: tuple, value: Any) -> Any:
    """``document`` with ``value`` at ``path``; a missing key on the way is made an object."""
    document = copy.deepcopy(document)
    node = document
    for step in path[:-1]:
        node = node.setdefault(step, {}) if isinstance(node, dict) else node[step]
    node[path[-1]] = value
    return document
