"""What the optimization changed, told by the files themselves: the input as IfcOpenShell writes it
(a snapshot taken before sharing) against the written output. Instance ids survive the rewrite
(IfcOpenShell keeps them and writes instances in id order), so an instance whose STEP line is the
same in both is the same instance with the same attribute values; only its inverse references can
differ, and those are found from the lines that did change."""

from __future__ import annotations

import re
from collections.abc import Iterator
from dataclasses import dataclass, field

_INSTANCE = re.compile(r"^#(\d+)\s*=(.*?);[ \t]*\r?$", re.MULTILINE | re.DOTALL)
_REFERENCE = re.compile(r"#(\d+)")


@dataclass
class Changes:
    changed: set[int] = field(default_factory=set)  # in both files, other attribute values
    new: set[int] = field(default_factory=set)  # only in the output
    removed: set[int] = field(default_factory=set)  # only in the input
    rewired: set[int] = field(default_factory=set)  # same line, but referenced by other instances now
    unchanged: int = 0

    @property
    def touched(self) -> set[int]:
        return self.changed | self.new | self.removed | self.rewired


def instance_lines(text: str) -> Iterator[tuple[int, str]]:
    """``(id, entity and attributes)`` of each instance of STEP text written by IfcOpenShell, in file
    order (a string holding ';' at a line end would cut a line short: that instance is then seen as
    changed, never as unchanged)."""
    start = text.find("\nDATA;")
    end = text.rfind("\nENDSEC;")
    body = text[start:end] if start >= 0 else text
    for match in _INSTANCE.finditer(body):
        yield int(match.group(1)), match.group(2)


def references(line: str) -> set[int]:
    """Ids a line refers to (a '#12' inside a string counts too: more is checked, never less)."""
    return {int(i) for i in _REFERENCE.findall(line)}


def diff(before: str, after: str) -> Changes:
    """Compare two STEP texts written by IfcOpenShell instance by instance, walking both in id order
    (sorting them first should a file not be in order)."""
    try:
        return _walk(_in_order(instance_lines(before)), _in_order(instance_lines(after)))
    except _Unordered:
        return _walk(iter(sorted(instance_lines(before))), iter(sorted(instance_lines(after))))


class _Unordered(Exception):
    pass


def _in_order(lines: Iterator[tuple[int, str]]) -> Iterator[tuple[int, str]]:
    last = -1
    for i, line in lines:
        if i <= last:
            raise _Unordered
        last = i
        yield i, line


def _walk(a_iter: Iterator[tuple[int, str]], b_iter: Iterator[tuple[int, str]]) -> Changes:
    out = Changes()
    a, b = next(a_iter, None), next(b_iter, None)
    while a is not None or b is not None:
        if b is None or (a is not None and a[0] < b[0]):
            out.removed.add(a[0])
            out.rewired |= references(a[1])
            a = next(a_iter, None)
        elif a is None or b[0] < a[0]:
            out.new.add(b[0])
            out.rewired |= references(b[1])
            b = next(b_iter, None)
        else:
            if a[1] == b[1]:
                out.unchanged += 1
            else:
                out.changed.add(a[0])
                out.rewired |= references(a[1]) ^ references(b[1])
            a, b = next(a_iter, None), next(b_iter, None)
    out.rewired -= out.changed | out.new | out.removed
    return out
