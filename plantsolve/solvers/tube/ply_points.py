"""PLY point clouds and meshes (ASCII, binary little and big endian), read so that a damaged file says so.

A general PLY reader stops at, or silently drops, what follows a cut: this one keeps every complete record
before the cut and logs the rest (``ReadLog``): a file ending before the records its header declares, an ASCII
record cut short or not numbers, a vertex with a NaN coordinate (then the faces using it go too). Faces are read
only for a sparse mesh, whose faces are sampled instead of its vertices (``faces_below``)."""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np

from plantsolve.schemas.common import MAX_COORDINATE, Diagnostic
from plantsolve.solvers.base import reject
from plantsolve.solvers.length_units import SIZES, comment_unit, two_readings
from plantsolve.solvers.tube.read_log import ReadLog

TYPES = {"char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1", "short": "i2", "int16": "i2", "ushort": "u2",
         "uint16": "u2", "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4", "float": "f4", "float32": "f4",
         "double": "f8", "float64": "f8"}


# A unit some scanners and converters state in a comment of the header (``comment units mm``, ``comment Unit: meter``,
# ``obj_info length_unit = millimetres``); the PLY format itself has none. A comment's unit is one word of letters
# (the header is ASCII, so no 'µm'): one of the request's units or micrometres (length_units), read; a word that says
# no unit is stated, no statement; any other word (``furlong``, ``yd``, ``dm``) states a unit this reader cannot
# convert, so the file is refused naming the line: read in the request's unit instead, a scan in yards or
# decimetres came back 914 or 100 times too small, a yard-stick tube plausible in millimetres without a word.
_COMMENT = re.compile(r"^(?:comment|obj_info)\s+(.*)$", re.IGNORECASE)


def stated_unit(content: bytes) -> tuple[str, str] | str | None:
    """The length unit a comment of the PLY header states, and the evidence (its line); a message when comments
    state two different units, or a unit this reader cannot convert; None when none states one."""
    end = content.find(b"end_header")
    if not content.startswith(b"ply") or end < 0:
        return None
    found = []
    for lineno, line in enumerate(content[:end].decode("ascii", errors="replace").splitlines(), 1):
        comment = _COMMENT.match(line.strip())
        stated = comment_unit(comment.group(1), SIZES) if comment else None
        if stated is None:
            continue
        word, unit = stated
        if (readings := two_readings(word)) is not None:
            return f"its header comment on line {lineno} ({line.strip()!r}) states the unit {readings}"
        if unit is None:
            return (f"its header comment on line {lineno} ({line.strip()!r}) states the unit {word!r}, "
                    f"which is no length unit read here ({', '.join(SIZES)})")
        found.append((unit, lineno, line.strip()))
    if len({unit for unit, _, _ in found}) > 1:
        return "its header comments state different units (" + ", ".join(
            f"line {n}: {text!r}" for _, n, text in found[:4]) + ")"
    if not found:
        return None
    unit, lineno, text = found[0]
    return unit, f"the PLY header's comment on line {lineno}: {text!r}"


@dataclass
class Prop:
    name: str
    type: str  # numpy type code without byte order
    count_type: str | None = None  # list properties: the type of the item count
    line: int = 0  # of the header


@dataclass
class Element:
    name: str
    count: int
    props: list[Prop]


@dataclass
class PlyData:
    """Vertices (N, 3) with NaN rows where a vertex could not be read (so that face indices stay valid), and the
    faces as triangles (M, 3) when they were read."""

    vertices: np.ndarray
    triangles: np.ndarray | None


def _header(content: bytes) -> tuple[str, list[Element], int, int]:
    """Format, elements, byte offset of the body and the number of header lines."""
    if not content.startswith(b"ply"):
        raise reject("not a PLY file (it does not start with 'ply')")
    end = content.find(b"end_header")
    if end < 0:
        raise reject("PLY header has no 'end_header' (the file is cut inside its header)")
    body = content.find(b"\n", end)
    body = len(content) if body < 0 else body + 1
    lines = content[:body].decode("ascii", errors="replace").splitlines()
    fmt, elements = None, []
    for lineno, line in enumerate(lines, 1):
        words = line.split()
        if not words or words[0] in ("ply", "comment", "obj_info", "end_header"):
            continue
        try:
            if words[0] == "format":
                fmt = words[1]
            elif words[0] == "element":
                if int(words[2]) < 0:  # numpy would read every record there is
                    raise ValueError
                elements.append(Element(words[1], int(words[2]), []))
            elif words[0] == "property" and words[1] == "list":
                elements[-1].props.append(Prop(words[4], TYPES[words[3]], TYPES[words[2]], lineno))
            elif words[0] == "property":
                elements[-1].props.append(Prop(words[2], TYPES[words[1]], line=lineno))
            else:
                raise ValueError
        except (IndexError, KeyError, ValueError):
            raise reject(f"PLY header line {lineno} not understood: {line[:60]!r}") from None
    if fmt not in ("ascii", "binary_little_endian", "binary_big_endian"):
        raise reject(f"PLY format {fmt!r} not understood")
    for el in elements:  # 'X Y Z' as some exporters capitalise them: the coordinates all the same
        names = {p.name for p in el.props}
        if not {"x", "y", "z"} & names and {"X", "Y", "Z"} <= names:
            for p in el.props:
                p.name = p.name.lower() if p.name in ("X", "Y", "Z") else p.name
    return fmt, elements, body, len(lines)


def elements(content: bytes) -> list[Element]:
    """The elements a PLY header declares (its records unread)."""
    return _header(content)[1]


def read_ply(content: bytes, log: ReadLog, faces_below: int) -> PlyData:
    fmt, elements, start, header_lines = _header(content)
    vertex = next((e for e in elements if e.name == "vertex"), None)
    if vertex is None or not {"x", "y", "z"} <= {p.name for p in vertex.props if p.count_type is None}:
        raise reject("PLY file has no vertex element with x, y, z")
    read = _read_ascii if fmt == "ascii" else _read_binary
    data = read(content, start, header_lines, elements, ">" if fmt == "binary_big_endian" else "<", log, faces_below)
    verts = data.get("vertex")
    if verts is None or not np.isfinite(verts).all(1).any():
        raise reject(f"PLY file holds no readable vertex{log.summary()}")
    faces = data.get("face")
    triangles = None
    if faces:
        tri = [(f[0], f[k], f[k + 1]) for f in faces for k in range(1, len(f) - 1)]  # polygons as fans
        triangles = np.asarray(tri, dtype=np.int64).reshape(-1, 3)
        ok = (triangles >= 0).all(1) & (triangles < len(verts)).all(1)
        ok[ok] = np.isfinite(verts[triangles[ok]]).all((1, 2))
        # faces on a vertex left out (or past the last): they go too
        log.skip(None, "face on a missing vertex", count=int((~ok).sum()))
        triangles = triangles[ok]
    return PlyData(verts, triangles)


def _faces_wanted(elements: list[Element], out: dict, faces_below: int) -> bool:
    """Whether a mesh's faces are read: a sparse mesh's are sampled, a dense one's vertices are the samples (the
    vertices read so far decide, or the count the header declares when the faces come first)."""
    read = out.get("vertex")
    return (len(read) if read is not None else next(e.count for e in elements if e.name == "vertex")) < faces_below


def _read_ascii(content, start, header_lines, elements, _order, log, faces_below) -> dict:
    lines = content[start:].decode("utf-8", errors="replace").splitlines()
    pos, out = 0, {}
    ends_mid_line = bool(lines) and not content.endswith((b"\n", b"\r"))
    for el in elements:
        if el.name == "face" and not _faces_wanted(elements, out, faces_below):
            if "vertex" in out:
                break  # a dense mesh: its vertices are the samples
            pos += el.count  # faces written before the vertices (a valid order): passed over, one a line
            continue
        if el.name not in ("vertex", "face"):
            pos += el.count  # one record a line
            continue
        lists = [p.name for p in el.props if p.count_type is not None]
        records: list = []
        for i in range(el.count):
            while pos < len(lines) and not lines[pos].strip():
                pos += 1
            if pos >= len(lines):
                log.truncate(f"the file ends after {i} of {el.count} {el.name} records (line "
                             f"{header_lines + pos})", element=el.name, read=i, declared=el.count)
                break
            lineno, words = header_lines + pos + 1, lines[pos].split()
            pos += 1
            rec, why = _ascii_record(el, words)
            if el.name == "vertex":
                if rec is not None and not all(math.isfinite(v) for v in (rec[p] for p in "xyz")):
                    rec, why = None, "non-finite coordinate"
                records.append([rec[c] for c in "xyz"] if rec else [math.nan] * 3)
            elif rec is not None:
                if not lists:
                    raise reject("PLY face element has no list of vertex indices")
                records.append(rec[lists[0]])
            if rec is None:
                if pos == len(lines) and ends_mid_line:
                    log.truncate(f"the file ends mid-record (line {lineno})", line=lineno)
                log.skip(lineno, why)
        out[el.name] = np.array(records, dtype=np.float64).reshape(-1, 3) if el.name == "vertex" else records
        if log.truncation:
            break
    else:
        extra = [k for k in range(pos, len(lines)) if lines[k].strip()]
        if extra:
            _beyond_header(log, elements, f"{len(extra)} more line(s) from line {header_lines + extra[0] + 1} on")
    return out


def _beyond_header(log: ReadLog, elements: list, what: str) -> None:
    """A warning that the file holds data past the records its header declares, which were not read: a header
    whose element count is smaller than what the exporter wrote leaves part of the scan out."""
    declared = ", ".join(f"{e.count} {e.name}" for e in elements)
    log.warn(Diagnostic(code="records_beyond_header", message=(
        f"PLY file: after the records its header declares ({declared}) it holds {what}, which were not read; is "
        "the header's element count wrong? Only the declared records were used."),
        details={"declared": {e.name: e.count for e in elements}}))


def _ascii_record(el: Element, words: list[str]) -> tuple[dict | None, str]:
    """One ASCII record as {property: value}, or None and why it is unreadable."""
    rec, k = {}, 0
    try:
        for p in el.props:
            if p.count_type is None:
                rec[p.name] = float(words[k])
                k += 1
            else:
                n = int(words[k])
                rec[p.name] = [int(w) for w in words[k + 1:k + 1 + n]]
                if len(rec[p.name]) < n:
                    return None, "cut short"
                k += 1 + n
    except IndexError:
        return None, "cut short"
    except ValueError:
        return None, "not numbers"
    return rec, ""


def _refuse_doubles_declared_float(content: bytes, start: int, elements: list[Element], order: str) -> None:
    """A 422 naming the header's first float property when the body holds exactly the bytes of the declared
    records written as 8-byte doubles and, read so, every vertex is a coordinate: read as the 4-byte floats the
    header declares, half the records would be the halves of doubles (noise that may pass as coordinates) and the
    other half bytes past the declared records."""
    floats = [p for e in elements for p in e.props if p.type == "f4"]
    if not floats or any(p.count_type is not None for e in elements for p in e.props):
        return
    as_doubles = [[(p.name, order + ("f8" if p.type == "f4" else p.type)) for p in e.props] for e in elements]
    size = sum(e.count * np.dtype(d).itemsize for e, d in zip(elements, as_doubles))
    if len(content) - start - size not in (0, 1, 2):  # a final newline (CRLF) after the records is no record
        return
    offset = start
    for e, d in zip(elements, as_doubles):
        if e.name == "vertex":
            rows = np.frombuffer(content, np.dtype(d), e.count, offset=offset)
            with np.errstate(invalid="ignore", over="ignore"):
                xyz = np.column_stack([rows[c] for c in "xyz"]).astype(np.float64)
            if len(xyz) == 0 or _garbled(xyz).any() or np.isnan(xyz).all():
                return
            break
        offset += e.count * np.dtype(d).itemsize
    first = floats[0]
    raise reject(f"PLY header line {first.line} ('property float {first.name}'): the body holds exactly the bytes of "
                 f"the declared records ({', '.join(f'{e.count} {e.name}' for e in elements)}) with 8-byte doubles "
                 "for its float properties, and read so every vertex is a coordinate; read as the 4-byte floats the "
                 "header declares they would be noise. Declare them 'property double' (or, if the file holds twice "
                 "the records, state that count)")


def _read_binary(content, start, _header_lines, elements, order, log, faces_below) -> dict:
    _refuse_doubles_declared_float(content, start, elements, order)
    pos, out = start, {}
    for el in elements:
        if el.name == "face" and "vertex" in out and not _faces_wanted(elements, out, faces_below):
            break
        if all(p.count_type is None for p in el.props):
            dt = np.dtype([(p.name, order + p.type) for p in el.props])
            n = min(el.count, (len(content) - pos) // dt.itemsize)
            rows = np.frombuffer(content, dt, n, offset=pos)
            pos += n * dt.itemsize
            if el.name == "vertex":
                with np.errstate(invalid="ignore", over="ignore"):  # a mistyped header's noise: refused below
                    out["vertex"] = np.column_stack([rows[c] for c in "xyz"]).astype(np.float64)
                _refuse_mistyped(out["vertex"], rows, order)
        else:
            rows, pos, n = _binary_lists(content, pos, el, order)  # faces before the vertices: passed over
            if el.name == "face" and _faces_wanted(elements, out, faces_below):
                out["face"] = rows
        if n < el.count:
            log.truncate(f"the file ends after {n} of {el.count} {el.name} records", element=el.name, read=n,
                         declared=el.count)
            break
        if el is elements[-1]:
            # every declared record read: a stray line ending after them is no record, a vertex's worth of bytes is
            vertex = next(e for e in elements if e.name == "vertex")
            if len(content) - pos >= max(_record_size(vertex, order), 8):
                _beyond_header(log, elements, f"{len(content) - pos} more bytes")
        if el.name == "vertex" and len(out["vertex"]) >= faces_below:
            break
    verts = out.get("vertex")
    if verts is not None:
        bad = ~np.isfinite(verts).all(1)
        log.skip(None, "non-finite coordinate", count=int(bad.sum()))
        verts[bad] = np.nan
    return out


def _garbled(xyz: np.ndarray) -> np.ndarray:
    """Vertices that are no coordinates: infinite, beyond 1e12, or NaN in some of x, y, z only (an organized scan
    writes a missing return as NaN in all three, which is no sign of a wrong header)."""
    nan = np.isnan(xyz)
    with np.errstate(invalid="ignore"):
        wild = (np.isinf(xyz) | (np.abs(xyz) > MAX_COORDINATE)).any(1)
    return wild | (nan.any(1) & ~nan.all(1))


def _refuse_mistyped(xyz: np.ndarray, rows: np.ndarray, order: str) -> None:
    """A 422 when most vertices are no coordinates at all: the header's types or byte order are not the data's (a
    big-endian file declared little-endian, doubles declared float), and what reads as finite among them is noise as
    well. Naming the byte order when the other one reads every vertex as a coordinate."""
    read = ~np.isnan(xyz).all(1)
    bad = _garbled(xyz)
    if not read.any() or bad.sum() <= 0.5 * read.sum():
        return
    swapped = rows.view(rows.dtype.newbyteorder())
    other = np.column_stack([swapped[c] for c in "xyz"]).astype(np.float64)
    declared = "binary_big_endian" if order == ">" else "binary_little_endian"
    hint = (f"; read in the other byte order every vertex is a coordinate: the header's 'format {declared}' is wrong"
            if not _garbled(other).any() else ": do the header's property types and byte order match the data?")
    raise reject(f"PLY file: {int(bad.sum())} of {len(xyz)} vertices are not coordinates (infinite, beyond "
                 f"{MAX_COORDINATE:g}, or NaN in one axis only) as its header describes them{hint}")


def _record_size(el: Element, order: str) -> int:
    """Bytes of one record of an element without lists (0 with lists: their records have no fixed size)."""
    if any(p.count_type is not None for p in el.props):
        return 0
    return np.dtype([(p.name, order + p.type) for p in el.props]).itemsize


def _binary_lists(content: bytes, pos: int, el: Element, order: str) -> tuple[list, int, int]:
    """Records with list properties, one by one (faces of sparse meshes only, so few); the list of the
    element's first list property per complete record, the offset after them and how many were complete."""
    size = {p: np.dtype(p).itemsize for p in TYPES.values()}
    first_list = next(p for p in el.props if p.count_type is not None)
    out = []
    for i in range(el.count):
        p0, item = pos, None
        try:
            for p in el.props:
                if p.count_type is None:
                    pos += size[p.type]
                    continue
                n = int(np.frombuffer(content, order + p.count_type, 1, offset=pos)[0])
                pos += size[p.count_type]
                vals = np.frombuffer(content, order + p.type, n, offset=pos)
                pos += n * size[p.type]
                if p is first_list:
                    item = [int(v) for v in vals]
            if pos > len(content):
                raise ValueError
        except ValueError:  # numpy: the buffer ends inside this record
            return out, p0, i
        out.append(item)
    return out, pos, el.count
