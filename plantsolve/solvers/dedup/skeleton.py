"""A model's faceted meshes read straight from its STEP text, and the rest of it parsed without them.

In a geometry-heavy model nearly every instance is a point, loop, bound or face under a faceted item
(``IfcFaceBasedSurfaceModel``, ``IfcShellBasedSurfaceModel``, ``IfcFacetedBrep``): the paper's tunnel
holds 2.5 M of them under 4,240 items and 50 k other instances. Parsing them into IfcOpenShell and
walking them one Python object at a time was most of the run and most of its memory. Here the text is
read in bulk with numpy: every line's id, entity and references, which instances lie under exactly one
item and nothing else refers to (the item's *closure*), and the closure's points in the order
IfcOpenShell's ``traverse`` visits them. The model IfcOpenShell parses (the *skeleton*) is the file
without those instances; the item's own children stay as empty stand-ins with their ids (the item's
references then resolve as in the whole file, and what the skeleton numbers next is what the whole
file would number). What the optimization keeps of a closure is parsed from the file's lines when the
output is written (:meth:`Skeleton.texts`).

The scan reads what it can vouch for and leaves the rest to IfcOpenShell: a file whose data section
is not one instance per line, has comments, repeated or sparse ids, or a faceted line written other
than plainly gives None (the caller parses the whole file); an item whose closure is shared with
anything, refers to anything but the next level of a faceted mesh, or holds a point that is not
three plain numbers stays in the skeleton whole, read as before."""

from __future__ import annotations

import os
import re
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

import ifcopenshell
import ifcopenshell.ifcopenshell_wrapper as wrapper
import numpy as np

from plantsolve.solvers.dedup import compaction, ifcio
from plantsolve.solvers.dedup.sharing import body_representation

ITEMS = (b"IFCFACEBASEDSURFACEMODEL", b"IFCSHELLBASEDSURFACEMODEL", b"IFCFACETEDBREP")
# what lies under a faceted item, by level: each refers only to the next level down
LEVELS = {b"IFCCONNECTEDFACESET": 1, b"IFCCLOSEDSHELL": 1, b"IFCOPENSHELL": 1, b"IFCFACE": 2,
          b"IFCFACEOUTERBOUND": 3, b"IFCFACEBOUND": 3, b"IFCPOLYLOOP": 4, b"IFCCARTESIANPOINT": 5}
NAMES = ITEMS + tuple(LEVELS)
LEVEL_OF = np.array([-1] + [0] * len(ITEMS) + list(LEVELS.values()), dtype=np.int8)  # by code; 0: not named
POINT_LEVEL, FACE_LEVEL = 5, 2
MAX_DIGITS = 10  # instance numbers below 2^31
CHUNK = 1 << 24
READ_GAP, READ_RUN = 1 << 12, 1 << 20  # lines closer than READ_GAP are read in one call of at most READ_RUN bytes
# the characters of a point's coordinates written plainly (no '$', '*', string, NaN or spaces)
_PLAIN = np.zeros(256, dtype=bool)
_PLAIN[np.frombuffer(b"0123456789.+-eE,", dtype=np.uint8)] = True


def _where(seg: np.ndarray, byte: int, at_least: bool = False) -> np.ndarray:
    """Positions of ``byte`` (or, ``at_least``, of any byte from it up) in ``seg``, a chunk at a time (no mask as
    long as the file; megabyte chunks were faster alone but left the scan's peak 7 MiB higher), made 32-bit before
    they are offset (the file is under 2 GiB)."""
    parts = []
    for i in range(0, len(seg), CHUNK):
        part = np.flatnonzero(seg[i:i + CHUNK] >= byte if at_least else seg[i:i + CHUNK] == byte).astype(np.int32)
        part += i
        parts.append(part)
    return np.concatenate(parts) if parts else np.zeros(0, dtype=np.int32)


def _has_comment(text: np.ndarray) -> bool:
    """Whether '/*' is in ``text``: its slashes found a megabyte at a time (``bytes.find`` of two bytes takes five
    times as long; chunks as large as the scan's would leave their freed pages with the process)."""
    step = 1 << 20
    for i in range(0, len(text) - 1, step):
        part = text[i:i + step + 1]
        if np.any(part[np.flatnonzero(part[:-1] == 47) + 1] == 42):
            return True
    return False


_IN_CACHE = 1 << 16
_LOW_NIBBLES = np.uint64(0x0F0F0F0F0F0F0F0F)
_HIGH_NIBBLES = np.uint64(0xF0F0F0F0F0F0F0F0)
_THREES = np.uint64(0x3030303030303030)
_SIXES = np.uint64(0x0606060606060606)


def _numbers(text: np.ndarray, pos: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The decimal numbers written at ``pos`` in ``text`` (which goes on at least 8 bytes past each) and how many
    digits each has (0 digits: value 0; -1: more than an instance number has). The eight bytes at each position
    are read as one 64-bit word and turned into a number with three multiplications (eight digits at once, as
    simdjson does); the few numbers of more than eight digits digit by digit."""
    value = np.empty(len(pos), dtype=np.int32)
    count = np.empty(len(pos), dtype=np.int8)
    table = np.lib.stride_tricks.as_strided(text, shape=(len(text) - 7, 8), strides=(1, 1))
    for c in range(0, len(pos), _IN_CACHE):  # a piece at a time: a dozen passes over what the cache holds
        words = table[pos[c:c + _IN_CACHE]].view("<u8")[:, 0]
        # a byte that is no digit: its high nibble is not 3, or its low nibble is past 9
        other = ((words & _HIGH_NIBBLES) ^ _THREES) | (((words & _LOW_NIBBLES) + _SIXES) & _HIGH_NIBBLES)
        lowest = other & (~other + np.uint64(1))  # the first byte that is no digit, as its lowest set bit
        n = np.where(other == 0, 8, np.log2(np.maximum(lowest, np.uint64(1)).astype(float)).astype(np.int64) // 8)
        digits = np.where(n == 0, np.uint64(0), (words & _LOW_NIBBLES) << (np.uint64(8) * (8 - n).astype(np.uint64)))
        digits = ((digits * np.uint64(2561)) >> np.uint64(8)) & np.uint64(0x00FF00FF00FF00FF)
        digits = ((digits * np.uint64(6553601)) >> np.uint64(16)) & np.uint64(0x0000FFFF0000FFFF)
        value[c:c + len(words)] = (digits * np.uint64(42949672960001)) >> np.uint64(32)
        count[c:c + len(words)] = n
    longer = np.flatnonzero(count == 8)
    if len(longer):
        slow, many = _slow_numbers(text, pos[longer].astype(np.int64))
        many[slow > np.iinfo(np.int32).max] = -1  # no instance number: past what IfcOpenShell addresses
        value[longer], count[longer] = np.minimum(slow, np.iinfo(np.int32).max), many
    return value, count


def _slow_numbers(text: np.ndarray, pos: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`_numbers` one digit at a time (numbers of eight digits or more)."""
    value = np.zeros(len(pos), dtype=np.int64)
    digits = np.zeros(len(pos), dtype=np.int64)
    going = np.ones(len(pos), dtype=bool)
    last = len(text) - 1
    for k in range(MAX_DIGITS + 1):
        digit = text[np.minimum(pos + k, last)] - np.uint8(48)
        going &= digit <= 9
        if not going.any():
            return value, digits
        value *= np.where(going, 10, 1)
        value += digit * going
        digits += going
    digits[going] = -1
    return value, digits


@dataclass
class LineIndex:
    """Where each instance of the scanned file is written, and how often it is referred to: what the proof
    compares the written file with (``changes.diff_indexed``), without reading the input again."""

    path: Path  # the STEP text
    line_of: np.ndarray = field(repr=False)  # id → its line (-1: no instance)
    starts: np.ndarray = field(repr=False)  # each line's first byte in the file
    ends: np.ndarray = field(repr=False)  # each line's end (its ';' included, its line break not)
    referenced: np.ndarray = field(repr=False)  # each line's references from the data section ('#12' in a string too)

    def lines(self, ids: np.ndarray) -> dict[int, str]:
        """``{id: the instance's STEP line}`` of those of ``ids`` the file holds (read as Latin-1, as the
        whole-file comparison reads it)."""
        ids = np.asarray(ids, dtype=np.int64)
        ids = ids[(ids >= 0) & (ids < len(self.line_of))]
        ids = ids[self.line_of[ids] >= 0]
        return {i: line.decode("latin-1") for i, line in zip(ids.tolist(), self.raw(self.line_of[ids]))}

    def raw(self, rows: np.ndarray) -> list[bytes]:
        """The text of lines ``rows``, in that order: read from the file in runs of nearby lines (a file mapped
        into memory would count every page it touched as the process's for as long as it is mapped)."""
        starts, ends = self.starts[rows].astype(np.int64), self.ends[rows].astype(np.int64)
        order = np.argsort(starts, kind="stable")
        out: list[bytes] = [b""] * len(rows)
        with open(self.path, "rb") as handle:
            fd = handle.fileno()
            k = 0
            while k < len(order):
                first = k  # a run: lines less than READ_GAP apart, at most READ_RUN long, read in one call
                while (k + 1 < len(order) and starts[order[k + 1]] - ends[order[k]] < READ_GAP
                       and ends[order[k + 1]] - starts[order[first]] <= READ_RUN):
                    k += 1
                at = int(starts[order[first]])
                block = os.pread(fd, int(ends[order[first:k + 1]].max()) - at, at)
                for j in order[first:k + 1].tolist():
                    out[j] = block[starts[j] - at:ends[j] - at]
                k += 1
        return out

    def references_to(self, ids: np.ndarray) -> np.ndarray:
        """How often the data section refers to each of ``ids`` (each an instance the file holds)."""
        return self.referenced[self.line_of[np.asarray(ids, dtype=np.int64)]]

    def ids(self) -> np.ndarray:
        """Every instance id of the file."""
        return np.flatnonzero(self.line_of >= 0)


@dataclass
class Skeleton:
    """What the scan of one file found (see the module's docstring)."""

    path: Path  # the STEP text
    skeleton: bytes  # the file without the closures' instances, the items' children as stand-ins
    points: dict[int, tuple[np.ndarray, int]]  # item id → (its points as traverse visits them, its face count)
    closures: dict[int, np.ndarray]  # item id → the ids of the item and everything under it
    entities: dict[int, Counter]  # item id → its closure's instances per entity
    inner: Counter  # instances per entity under the items, their stand-ins excluded
    parsed: dict[int, np.ndarray]  # item id → the ids of it in the skeleton: itself and its stand-ins
    parsed_entities: dict[int, Counter]  # item id → those instances per entity
    instances: int  # in the whole file
    index: LineIndex = field(repr=False)  # each instance's line and how often it is referred to

    def model(self) -> ifcopenshell.file:
        """The skeleton parsed by IfcOpenShell (the same bytes as in the file: IfcOpenShell takes text as UTF-8)."""
        return ifcopenshell.file.from_string(self.skeleton.decode("utf-8"))

    def texts(self, ids: np.ndarray, header: str, trailer: str) -> dict[int, str]:
        """``{id: STEP text as IfcOpenShell writes it}`` of instances under the items (and the items'
        children): their lines read from the file and parsed on their own (a closure refers only within
        itself)."""
        lines_text = b"\n".join(self.index.raw(self.index.line_of[ids]))
        part = ifcopenshell.file.from_string(f"{header}DATA;\n{lines_text.decode('ascii')}\n{trailer}")
        by_id = part.by_id
        return {i: by_id(i).to_string() for i in ids.tolist()}


def read(path: Path, schema: str | None = None) -> Skeleton | None:
    """The file's faceted items read from its text, or None when the scan cannot vouch for the file."""
    data = Path(path).read_bytes()
    if len(data) >= 1 << 31:  # positions are held in 32 bits
        return None
    at = data.find(b"\nDATA;")
    if at < 0:
        return None
    body = data.find(b"\n", at + 1) + 1
    end = data.rfind(b"\nENDSEC;", body)  # a second section's lines would not start with '#': refused below
    if body <= 0 or end < 0:
        return None
    seg = np.frombuffer(data, dtype=np.uint8)[body:]  # the data section and, past it, at least its ENDSEC line
    if _has_comment(seg[:end - body + 1]):
        return None
    got = _scan(seg, end + 1 - body)
    if got is None:
        return None
    ids, starts, ends, names_at, code, name_len, src, dst, line_of = got
    offsets = (starts + body, ends + body)  # of each line in the file (without its line break)
    n = len(ids)
    level = LEVEL_OF[code]
    bad = np.zeros(n, dtype=bool)
    # a line with other than ASCII stays in the skeleton (its closure's text is parsed as ASCII)
    bad[np.searchsorted(starts, _where(seg[:end + 1 - body], 128, at_least=True), side="right") - 1] = True
    ok = np.ones(len(src), dtype=bool)
    faceted = level[src] >= 0
    # a faceted line refers to the next level only; an instance under an item referred to from outside is no closure's
    ok[faceted] = (dst[faceted] >= 0) & (level[np.maximum(dst[faceted], 0)] == level[src[faceted]] + 1)
    bad[src[faceted & ~ok]] = True
    outside = ~faceted & (dst >= 0)
    outside &= level[np.maximum(dst, 0)] >= 1
    bad[dst[outside]] = True
    label = -np.arange(1, n + 1, dtype=np.int32)  # every line its own; an item's closure takes its item's
    items = np.flatnonzero(level == 0)
    label[items] = items + 1
    conflict: list[np.ndarray] = []
    edge_level = np.where(faceted & ok, level[src], np.int8(-1))
    for depth in range(POINT_LEVEL):
        e = np.flatnonzero(edge_level == depth)
        s, d = label[src[e]], dst[e]
        label[d] = s
        split = label[d] != s  # under two items (or an item and a stray line): neither item's closure
        conflict += [s[split], label[d[split]]]
    bad_labels = set(np.unique(label[bad]).tolist())
    for part in conflict:
        bad_labels.update(part.tolist())
    # the largest id stays in the skeleton (what IfcOpenShell numbers next follows it)
    last = int(np.argmax(ids))
    if level[last] >= 2:
        bad_labels.add(int(label[last]))
    points = np.flatnonzero((level == POINT_LEVEL) & (label > 0))
    coords, dims = _coordinates(seg, names_at[points], ends[points])
    if coords is None:
        return None
    bad_labels.update(np.unique(label[points[dims != 3]]).tolist())
    has_points = np.zeros(n, dtype=bool)
    has_points[label[points] - 1] = True
    bad_labels.update((items[~has_points[items]] + 1).tolist())
    good = np.zeros(n + 1, dtype=bool)
    good[items + 1] = True
    if bad_labels:
        listed = np.fromiter(bad_labels, dtype=np.int64, count=len(bad_labels))
        good[listed[(listed > 0) & (listed <= n)]] = False
    member = (label > 0) & good[np.maximum(label, 0)] & (level >= 0)
    del bad, ok, faceted, outside, edge_level, good, has_points
    text = _skeleton_text(data, body, end, seg, ids, starts, names_at, name_len, level, member)
    names = _entity_names(data[:body], schema)
    del data, seg, starts, names_at, name_len
    return _items(Path(path), text, ids, offsets, code, level, label, member, points, coords, dims, src, dst,
                  names, line_of)


def _scan(seg: np.ndarray, length: int):
    """Every line's id, extent, entity name position, code (0: not a faceted name) and name length, and every
    reference (source line, target line or -1), or None when the data section (the first ``length`` bytes of
    ``seg``) is not one instance per line."""
    nl = _where(seg[:length], 10)
    if not len(nl) or nl[-1] != length - 1:
        return None
    starts = np.concatenate([np.zeros(1, dtype=np.int32), nl[:-1] + 1])
    ends = nl - (seg[np.maximum(nl - 1, 0)] == 13)
    if np.any(ends <= starts) or np.any(seg[starts] != 35) or np.any(seg[ends - 1] != 59):
        return None
    hashes = _where(seg[:length], 35)
    opens = np.ones(len(hashes), dtype=bool)  # a '#' that starts a line (the first is the data section's first)
    opens[1:] = seg[hashes[1:] - 1] == 10
    if int(np.count_nonzero(opens)) != len(starts):
        return None
    numbers, digits = _numbers(seg, hashes + 1)
    # the lines' '#' taken by index (one pass over the mask, not one per array); each line's references are
    # the '#'s up to the next line's: their source repeated that often (no running count over every '#')
    line_at = np.flatnonzero(opens).astype(np.int32)
    ids, id_digits = numbers[line_at], digits[line_at]
    after = hashes[line_at] + 1 + id_digits
    refs = ~opens
    numbers, digits = numbers[refs], digits[refs]
    src = np.repeat(np.arange(len(line_at), dtype=np.int32), np.diff(line_at, append=len(opens)) - 1)
    del hashes, refs, line_at
    if np.any(id_digits <= 0) or np.any(seg[after] != 61):
        return None
    n = len(ids)
    size = int(ids.max()) + 1
    if size > 8 * n + (1 << 24):
        return None
    line_of = np.full(size, -1, dtype=np.int32)
    line_of[ids] = np.arange(n, dtype=np.int32)
    if not np.array_equal(line_of[ids], np.arange(n)):  # an id written twice
        return None
    names_at = after + 1
    for _ in range(4):
        space = seg[names_at] == 32
        if not space.any():
            break
        names_at += space
    if int(names_at.max()) + 32 > len(seg) - 8:  # a name too near the end to be read as words (no real file's)
        return None
    code = np.zeros(n, dtype=np.int8)
    table = np.lib.stride_tricks.as_strided(seg, shape=(len(seg) - 7, 8), strides=(1, 1))
    first_word = table[names_at].view("<u8")[:, 0]  # each name's first eight bytes
    # every name with its '(' is at least eight bytes long: its first word is compared whole, all names' in one
    # sorted search, and each name's further words only on the lines whose first word is its
    firsts = np.unique(np.array([_words(name + b"(")[0][0] for name in NAMES], dtype=np.uint64))
    at = np.searchsorted(firsts, first_word).astype(np.uint8)
    np.minimum(at, len(firsts) - 1, out=at)
    candidates = np.flatnonzero(firsts[at] == first_word).astype(np.int32)  # lines of a name's first word
    at = at[candidates]  # which first word
    del first_word
    for k, name in enumerate(NAMES, start=1):
        words = _words(name + b"(")
        rows = candidates[at == np.searchsorted(firsts, words[0][0])]
        for w, part in enumerate(words[1:], start=1):
            if part is None:
                continue
            value, mask = part
            rows = rows[table[names_at[rows] + 8 * w].view("<u8")[:, 0] & mask == value]
        code[rows] = k
    del candidates, at
    name_len = np.array([0] + [len(name) for name in NAMES], dtype=np.int16)[code]
    dst = np.where((numbers < size) & (digits > 0), line_of[np.minimum(numbers, size - 1)], -1).astype(np.int32)
    return ids, starts, ends, names_at, code, name_len, src, dst, line_of


def _words(name: bytes) -> list[tuple[np.uint64, np.uint64] | None]:
    """``name`` as the 64-bit words :func:`_scan` reads (value, mask), one per eight bytes (None: past it)."""
    out = []
    for k in range(0, 32, 8):
        part = name[k:k + 8]
        if not part:
            out.append(None)
            continue
        out.append((np.uint64(int.from_bytes(part.ljust(8, b"\0"), "little")),
                    np.uint64(int.from_bytes(b"\xff" * len(part) + b"\0" * (8 - len(part)), "little"))))
    return out


POINTS_AT_ONCE = 1 << 16


def _coordinates(seg: np.ndarray, names_at: np.ndarray, ends: np.ndarray) -> tuple[np.ndarray | None, np.ndarray]:
    """The coordinates of the point lines (``#i=IFCCARTESIANPOINT((x,y,z));``) in one array and how many each
    has; None when one is not written plainly. A few thousand points at a time (their text is copied out)."""
    nothing = np.zeros(0, dtype=np.int64)
    first = names_at + len(b"IFCCARTESIANPOINT((")
    last = ends - len(b"));")
    if not len(first):
        return np.zeros(0), nothing
    if (np.any(seg[first - 1] != 40) or np.any(seg[first - 2] != 40) or np.any(seg[last] != 41)
            or np.any(seg[last + 1] != 41) or np.any(last <= first)):
        return None, nothing
    values, dims = [], []
    for c in range(0, len(first), POINTS_AT_ONCE):
        a, b = first[c:c + POINTS_AT_ONCE], last[c:c + POINTS_AT_ONCE]
        width = b - a + 1  # each point's numbers and the ')' after them, which becomes a comma
        offset = np.cumsum(width, dtype=np.int32)  # within the file, under 2 GiB (read): half the index's bytes
        text = seg[np.repeat(a - (offset - width), width) + np.arange(offset[-1], dtype=np.int32)]
        if np.count_nonzero(text == 41) != len(a):
            return None, nothing
        text[offset - 1] = 44
        if not _PLAIN[text].all():
            return None, nothing
        count = np.diff(np.searchsorted(np.flatnonzero(text == 44), offset - 1, side="right"), prepend=0)
        got = np.fromstring(text[:-1].tobytes(), dtype=float, sep=",")
        if len(got) != int(count.sum()):
            return None, nothing
        values.append(got)
        dims.append(count)
    values, dims = np.concatenate(values), np.concatenate(dims)
    if not np.isfinite(values).all():
        return None, dims
    return values, dims


def _skeleton_text(data: bytes, body: int, end: int, seg: np.ndarray, ids, starts, names_at, name_len, level,
                   member) -> bytes:
    """The file without the closures' lines, the items' children as empty stand-ins after the other lines."""
    keep = ~(member & (level >= 1))
    children = member & (level == 1)
    change = np.flatnonzero(np.diff(np.concatenate([[0], keep.astype(np.int8), [0]])))
    line_end = np.concatenate([starts[1:], [end + 1 - body]])
    stand_ins = b"".join(b"#%d=%s(());\n" % (i, seg[a:a + w].tobytes()) for i, a, w in
                         zip(ids[children].tolist(), names_at[children].tolist(), name_len[children].tolist()))
    pieces = [data[:body]]
    pieces += [data[body + starts[a]:body + line_end[b - 1]] for a, b in change.reshape(-1, 2).tolist()]
    pieces += [stand_ins, data[end + 1:]]
    return b"".join(pieces)


def _items(path, text, ids, offsets, code, level, label, member, points, coords, dims, src, dst, names,
           line_of) -> Skeleton:
    """The skeleton's items: their points as traverse visits them, closures and entity counts."""
    n = len(ids)
    item_lines = np.flatnonzero(member & (level == 0))
    # the points of each item as traverse visits them: its children in order, level by level, each point at its
    # first visit
    faceted = level[src] >= 0
    faceted[faceted] = (dst[faceted] >= 0) & (level[np.maximum(dst[faceted], 0)] == level[src[faceted]] + 1)
    fsrc, fdst = src[faceted], dst[faceted]
    # how often each line is referred to (what the proof compares the written file's references with)
    referenced = np.bincount(dst[dst >= 0], minlength=n).astype(np.int32)
    del faceted, src, dst
    first_child = np.zeros(n + 1, dtype=np.int32)
    np.cumsum(np.bincount(fsrc, minlength=n), out=first_child[1:])
    degree = np.diff(first_child)
    del fsrc
    seq, owner = item_lines.astype(np.int32), np.arange(len(item_lines), dtype=np.int32)
    for _ in range(POINT_LEVEL):
        count = degree[seq]
        total = int(count.sum())
        base = np.repeat(first_child[seq] - (np.cumsum(count, dtype=np.int32) - count), count)
        seq, owner = fdst[base + np.arange(total, dtype=np.int32)], np.repeat(owner, count)
        del base
    first_visit = np.full(n, -1, dtype=np.int32)
    # of repeated indices the last written stays: each line's first place in the sequence
    first_visit[seq[::-1]] = np.arange(len(seq) - 1, -1, -1, dtype=np.int32)
    visit = first_visit[seq] == np.arange(len(seq))
    point_lines, point_owner = seq[visit], owner[visit]
    del first_visit, visit, seq, owner, fdst, degree, first_child
    row = np.full(n, -1, dtype=np.int32)
    row[points] = np.arange(len(points), dtype=np.int32)
    point_start = np.concatenate([[0], np.cumsum(dims)])
    per_item = np.bincount(point_owner, minlength=len(item_lines))
    bounds = np.concatenate([[0], np.cumsum(per_item)])
    faces = np.bincount(np.searchsorted(item_lines, label[member & (level == FACE_LEVEL)] - 1),
                        minlength=len(item_lines))
    result_points = {}
    for k, line in enumerate(item_lines.tolist()):
        rows = row[point_lines[bounds[k]:bounds[k + 1]]]
        result_points[int(ids[line])] = (coords[point_start[rows][:, None] + np.arange(3)], int(faces[k]))
    # closures: ids of every line with the item's label
    lines = np.flatnonzero(member)
    lines = lines[np.argsort(label[lines], kind="stable")]
    cuts = np.searchsorted(label[lines], item_lines + 1, side="left")
    cuts = np.append(cuts, len(lines))
    which = np.searchsorted(item_lines, label[lines] - 1)
    codes = len(NAMES) + 1
    counts = np.bincount(which * codes + code[lines], minlength=len(item_lines) * codes).reshape(-1, codes)
    top = level[lines] <= 1
    counts_top = np.bincount(which[top] * codes + code[lines[top]],
                             minlength=len(item_lines) * codes).reshape(-1, codes)
    closures, entities, parsed, parsed_entities = {}, {}, {}, {}
    for k, line in enumerate(item_lines.tolist()):
        mine = lines[cuts[k]:cuts[k + 1]]
        i = int(ids[line])
        closures[i] = ids[mine]
        entities[i] = Counter({names[c]: int(v) for c, v in enumerate(counts[k]) if v})
        parsed[i] = ids[mine[level[mine] <= 1]]
        parsed_entities[i] = Counter({names[c]: int(v) for c, v in enumerate(counts_top[k]) if v})
    inner_lines = member & (level >= 2)
    inner = Counter({names[c]: int(v) for c, v in enumerate(np.bincount(code[inner_lines], minlength=len(NAMES) + 1))
                     if v})
    line_start, line_end = offsets
    return Skeleton(path, text, result_points, closures, entities, inner, parsed, parsed_entities, n,
                    LineIndex(path, line_of, line_start, line_end, referenced))


def _entity_names(header: bytes, schema: str | None) -> list[str]:
    """The names of the codes as IfcOpenShell spells them ('IfcCartesianPoint')."""
    if schema is None:
        found = re.search(rb"FILE_SCHEMA\s*\(\s*\(\s*'([A-Za-z0-9_]+)", header)
        schema = found.group(1).decode() if found else "IFC4"
    try:
        declared = wrapper.schema_by_name(schema.upper())
        return [""] + [declared.declaration_by_name(name.decode()).name() for name in NAMES]
    except Exception:  # noqa: BLE001 (an unknown schema: the whole parse refuses it, by name)
        return [""] + [name.decode() for name in NAMES]


def compacted(model: ifcopenshell.file, skeleton: Skeleton, roots, styled_by: dict[int, list], *,
              known: dict[int, np.ndarray], everything: np.ndarray) -> ifcopenshell.file:
    """``compaction.compacted`` of a skeleton model, always rebuilt: what goes is found in the skeleton (an item's
    closure goes or stays with it: nothing outside refers into it), the closures of the items that stay are
    parsed from the file's lines, and the new model holds both, ids unchanged."""
    gone, everything = compaction.going(model, roots, styled_by, known=known, everything=everything)
    keep = np.setdiff1d(everything, gone, assume_unique=True)
    items = np.fromiter(skeleton.closures, dtype=np.int64, count=len(skeleton.closures))
    staying = items[np.isin(items, keep)].tolist()
    inner = [c[c != i] for i in staying for c in (skeleton.closures[i],)]
    from_file = np.concatenate(inner) if inner else np.zeros(0, dtype=np.int64)
    head, tail = compaction.frame(model)
    texts = skeleton.texts(from_file, head, tail) if len(from_file) else {}
    return compaction.rebuilt(model, np.union1d(keep, from_file), texts)


def open_model(path: Path) -> tuple[ifcopenshell.file, Skeleton | None]:
    """The model to optimize: the skeleton when the scan vouches for the file and the skeleton passes the checks
    a whole model must, else the whole file (whose refusals then name what is wrong with it)."""
    try:
        found = read(path)
    except Exception:  # noqa: BLE001 (text the scan did not foresee: the whole parse reads it, or refuses it by name)
        found = None
    if found is not None:
        try:
            model = found.model()
            ifcio.check_model(model, found.instances)
        except Exception:  # noqa: BLE001 (a refusal or a parse error: the whole file says which, in its words)
            pass
        else:
            # every line of the skeleton is one instance (the scan vouches for it): one fewer is one IfcOpenShell
            # could not read, and an entity written with another number of attributes than the schema's is of
            # another schema, which the whole file's parse names
            if len(model.entity_names()) == found.skeleton.count(b"\n#") + found.skeleton.startswith(b"#") and \
                    not ifcio.misfits_schema(model, found.skeleton, found.index.lines):
                return model, found
    log = ifcio.parser_log()
    model = ifcio.open_path(str(path), log)
    text = Path(path).read_bytes()
    if len(model.entity_names()) < ifcio.defined_instances(text):
        ifcio.refuse_unread(text, model)
    ifcio.refuse_attribute_counts(log, model, text)
    return model, None


def rebuild_expected(skeleton: Skeleton, walked: dict[int, np.ndarray], classes: list) -> bool:
    """Whether the compaction will most likely rebuild the model (see ``compaction.compacted``): the members'
    old bodies, by the sizes of their items' closures, against what stays."""
    gone = 0
    for cls in classes:
        for cand, _ in cls.members[1:]:
            body = body_representation(cand.product)
            for item in body.Items or ():
                got = skeleton.closures.get(item.id())
                if got is None:
                    got = walked.get(item.id(), ())
                gone += len(got)
    total = skeleton.instances
    return (total - gone) * compaction.WRITE_KEPT_US < gone * compaction.REMOVE_US
