"""What the optimization changed, told by the files themselves: the input file as it was uploaded
against the written output. Instance ids survive the rewrite (IfcOpenShell keeps them), so an instance
whose STEP line holds the same values in both is the same instance; only its inverse references can
differ, and those are found from the lines that did change and from how often each surviving
instance is referred to in either file.

The input is read in pieces, each parsed at C speed by one regular expression (no Python step per
input line): the output is small, the input may be a hundred megabytes of geometry the optimization
removed."""

from __future__ import annotations

import re
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from plantsolve.solvers.dedup.skeleton import LineIndex

_INSTANCE = re.compile(r"^#(\d+)\s*=(.*);[ \t]*\r?$", re.MULTILINE)  # one instance a line (quick)
_INSTANCE_LINES = re.compile(r"^#(\d+)\s*=(.*?);[ \t]*\r?$", re.MULTILINE | re.DOTALL)  # or over several
_CONTINUED = re.compile(r"\n(?!#|DATA;|ENDSEC;|[ \t]*\r?(?:\n|$))")  # a line that does not start an instance
_REFERENCE = re.compile(r"#(\d+)")
# a STEP value's tokens: strings, references, enumerations, names, numbers, any other character
_TOKEN = re.compile(r"'(?:[^']|'')*'|#\d+|\.[A-Za-z0-9_]+\.|[A-Za-z_][A-Za-z0-9_]*|"
                    r"[-+]?\d+(?:\.\d*)?(?:[eE][-+]?\d+)?|\S")
_NUMBER = re.compile(r"[-+]?\d")
CHUNK_CHARS = 1 << 22


@dataclass
class Changes:
    changed: set[int] = field(default_factory=set)  # in both files, other attribute values
    new: set[int] = field(default_factory=set)  # only in the output
    rewired: set[int] = field(default_factory=set)  # in both, same values, referenced by other instances now
    unchanged: int = 0
    _before: str | None = field(default=None, repr=False)
    _output_ids: set[str] = field(default_factory=set, repr=False)
    _removed: set[int] | None = field(default=None, repr=False)
    _input_ids: Callable[[], np.ndarray] | None = field(default=None, repr=False)  # the input's, when indexed

    @property
    def removed(self) -> set[int]:
        """Only in the input (read again when asked: only an output with errors needs them)."""
        if self._removed is None:
            self._removed = set()
            if self._input_ids is not None:
                self._removed = set(self._input_ids().tolist()) - {int(i) for i in self._output_ids}
            for piece in _pieces(self._before or ""):
                self._removed.update(int(i) for i in _instances(piece).keys() - self._output_ids)
        return self._removed

    def release(self) -> None:
        """Forget the input's text (the removed ids, once asked for, stay)."""
        self._before = None


def _bounds(text: str) -> tuple[int, int]:
    """Where the DATA section's instances are in STEP text (the whole text if it has no DATA line)."""
    start = text.find("\nDATA;")
    end = text.rfind("\nENDSEC;")
    start = max(start, 0)
    return start, end if end > start else len(text)


def _pieces(text: str, size: int | None = None):
    """``text``'s DATA section in pieces of about ``size`` characters, each cut where an instance begins
    (slices of the text: never a copy of all of it)."""
    size = size or CHUNK_CHARS
    start, stop = _bounds(text)
    while start < stop:
        end = text.find("\n#", start + size, stop)
        end = stop if end < 0 else end
        yield text[start:end + 1]
        start = end + 1


def _instances(piece: str) -> dict[str, str]:
    """``{id: entity and values}`` of a piece of STEP text."""
    return dict((_INSTANCE_LINES if _CONTINUED.search(piece) else _INSTANCE).findall(piece))


def same_values(a: str, b: str) -> bool:
    """Whether two STEP instance texts hold the same values, however they are written: blanks and line
    breaks outside strings, the case of names, and how a number is spelt ('1.E-05', '1.00000000000E-5')
    do not matter; strings are compared as written."""
    if a == b:
        return True
    ta, tb = _TOKEN.findall(a), _TOKEN.findall(b)
    if len(ta) != len(tb):
        return False
    for x, y in zip(ta, tb):
        if x == y:
            continue
        if x[0] == "'" or y[0] == "'":
            return False
        if _NUMBER.match(x) and _NUMBER.match(y):
            if float(x) != float(y):
                return False
        elif x.upper() != y.upper():
            return False
    return True


def references(line: str) -> set[int]:
    """Ids a line refers to (a '#12' inside a string counts too: more is checked, never less)."""
    return {int(i) for i in _REFERENCE.findall(line)}


def diff(before: str, after: str) -> Changes:
    """Compare the input's STEP text with the output's (written by IfcOpenShell), instance by instance."""
    data = after[slice(*_bounds(after))]
    out_lines = _instances(data)
    out_ids = set(out_lines)
    in_refs: Counter = Counter()
    seen: set[str] = set()
    was: dict[str, str] = {}  # the input's text of the changed instances
    unchanged = 0
    for piece in _pieces(before):
        lines = _instances(piece)
        for i in lines.keys() & out_ids:
            if same_values(lines[i], out_lines[i]):
                unchanged += 1
            else:
                was[i] = lines[i]
        seen.update(lines.keys() & out_ids)
        refs = Counter(_REFERENCE.findall(piece))
        for i in refs.keys() & out_ids:
            in_refs[i] += refs[i]
    changes = _judged(out_lines, Counter(_REFERENCE.findall(data)), seen, was, in_refs, unchanged)
    changes._before = before
    return changes


def diff_indexed(before: LineIndex, after: str) -> Changes:
    """:func:`diff` against an input the scan indexed (``skeleton.LineIndex``, a file of one instance a line):
    only the input's lines of the output's ids are read, and how often the input refers to each is the
    scan's count; the same changes as :func:`diff` finds."""
    data = after[slice(*_bounds(after))]
    out_lines = _instances(data)
    lines = before.lines(np.fromiter(map(int, out_lines), dtype=np.int64, count=len(out_lines)))
    seen = {str(i) for i in lines}
    was: dict[str, str] = {}
    unchanged = 0
    for i, line in lines.items():
        key = str(i)
        text = line[line.index("=") + 1:-1]  # as _INSTANCE reads the line: past '=', without its ';'
        if same_values(text, out_lines[key]):
            unchanged += 1
        else:
            was[key] = text
    counts = before.references_to(np.fromiter(lines, dtype=np.int64, count=len(lines)))
    # the line defining an instance counts as one of its '#12's, as in the whole text
    in_refs = Counter({str(i): int(n) + 1 for i, n in zip(lines, counts.tolist())})
    changes = _judged(out_lines, Counter(_REFERENCE.findall(data)), seen, was, in_refs, unchanged)
    changes._input_ids = before.ids
    return changes


def _judged(out_lines: dict[str, str], out_refs: Counter, seen: set[str], was: dict[str, str], in_refs: Counter,
            unchanged: int) -> Changes:
    """The changes, from the output's instances and how often each is referred to, the input's ids among
    them (``seen``), the input's text of those that differ and how often the input refers to each."""
    out_ids = set(out_lines)
    new = out_ids - seen
    rewired: set[int] = set()
    for i in new:
        rewired |= references(out_lines[i])
    for i, line in was.items():
        rewired |= references(line) ^ references(out_lines[i])
    # referred to as often in both files: any referrer lost to a removed or changed line was made up for
    # by a new or changed one, which is counted above (a '#12=' defining an instance counts on both sides)
    rewired.update(int(i) for i in seen if in_refs[i] != out_refs[i])
    rewired &= {int(i) for i in out_ids}  # a removed instance is looked at as removed
    changed = {int(i) for i in was}
    new_ids = {int(i) for i in new}
    return Changes(changed=changed, new=new_ids, rewired=rewired - changed - new_ids, unchanged=unchanged,
                   _output_ids=out_ids)
