"""Uploaded scan files read into a request; large point sets travel in it as base64 NPY (decoded by ``scan``).

Each format's unit convention is applied (``_conversion``: LAS/LAZ the unit of the file's CRS, metres when it
states none; E57 metres; the others the request's unit; ``options.file_units`` overrides), and what the readers
left out of a damaged file is reported (``ReadLog``): both travel in the request's ``source`` into the report."""

from __future__ import annotations

import base64
import io
import math

import numpy as np

from plantsolve.schemas.common import MAX_COORDINATE, Diagnostic
from plantsolve.schemas.tube import MAX_POINTS, PointSource, TubeRequest, UnitConversion
from plantsolve.solvers.base import FieldError, InputRejected, StoredInput, json_object, reject
from plantsolve.solvers.length_units import SIZES
from plantsolve.solvers.other_kinds import file_holds
from plantsolve.solvers.tube.las_units import CrsUnit, las_crs_unit, short_name
from plantsolve.solvers.tube.ply_points import elements as ply_elements
from plantsolve.solvers.tube.ply_points import read_ply
from plantsolve.solvers.tube.ply_points import stated_unit as stated_ply_unit
from plantsolve.solvers.tube.read_log import ReadLog
from plantsolve.solvers.tube.stl_points import read_stl
from plantsolve.solvers.tube.text_points import read_text_points
from plantsolve.solvers.tube.validation import EXTENT_MM_PLAUSIBLE, UNIT_MM, likely_units, scan_extent
from plantsolve.solvers.upload_form import FormRules, merged, read_form, validated_request

UPLOAD_EXTENSIONS = (".ply", ".stl", ".obj", ".e57", ".las", ".laz", ".xyz", ".csv", ".txt", ".npy", ".json")
TO_MM = UNIT_MM  # millimetres per unit of each unit a file's coordinates may be in (micrometres too)
# a mesh with fewer vertices than this is a CAD-style tessellation: its faces are sampled instead
MESH_MIN_VERTICES = 2000
MESH_SAMPLES = 20_000
INLINE_LIST_MAX = 20_000  # larger uploads travel inside the request as base64 NPY


def points_field(pts: np.ndarray):
    """The ``points`` value for an array: a JSON list when small, base64 NPY otherwise."""
    if len(pts) <= INLINE_LIST_MAX:
        return pts.tolist()
    buf = io.BytesIO()
    np.save(buf, np.ascontiguousarray(pts, dtype=np.float64))
    return {"npy_base64": base64.b64encode(buf.getvalue()).decode("ascii")}


def _canonical_triangles(corners: np.ndarray) -> np.ndarray:
    """Triangles (m, 3, 3) in one order whatever order the file wrote them in: each one's corners by their
    coordinates, the triangles by theirs. The seeded samples on the faces follow the faces' order and each face's
    first corner, so the same mesh exported with its faces or corners in another order was read to other samples
    and fitted to another answer."""
    flat = corners.reshape(-1, 3)
    rank = np.empty(len(flat), dtype=np.int64)
    rank[np.lexsort(flat.T[::-1])] = np.arange(len(flat))
    within = np.argsort(rank.reshape(-1, 3), axis=1)
    corners = np.take_along_axis(corners, within[:, :, None], axis=1)
    return corners[np.lexsort(corners.reshape(len(corners), 9).T[::-1])]


def _mesh_points(vertices: np.ndarray, triangles: np.ndarray | None, file_type: str, log: ReadLog) -> np.ndarray:
    """A mesh's samples: its vertices, or, for a sparse CAD-style tessellation, samples on its faces (seeded, so
    the same file gives the same points). Vertices left out by the reader are NaN rows here and are dropped."""
    import trimesh

    finite = np.isfinite(vertices).all(1)
    if triangles is not None and len(triangles) and finite.sum() < MESH_MIN_VERTICES:
        corners = _canonical_triangles(vertices[triangles])
        mesh = trimesh.Trimesh(corners.reshape(-1, 3), np.arange(corners.shape[0] * 3).reshape(-1, 3), process=False)
        if mesh.area > 0:
            pts, _ = trimesh.sample.sample_surface(mesh, MESH_SAMPLES, seed=0)
            return np.asarray(pts, dtype=np.float64)
    if not finite.any():
        raise reject(f"{file_type.upper()} file holds no vertices{log.summary()}")
    vertices = vertices[finite].astype(np.float64)
    if triangles is not None and len(triangles):
        # a mesh written triangle by triangle repeats each corner on every face: one sample per vertex, as STL's
        first = _first_of_each(vertices)
        return vertices if first is None else vertices[first]
    return vertices


def _obj_checked(content: bytes, log: ReadLog) -> bytes:
    """OBJ text with each unreadable vertex line (cut short, not numbers, NaN) made a NaN vertex, so that the face
    indices after it keep their meaning and the faces on it can be dropped, and each face line with fewer than
    three corners made a comment; both logged with their line numbers."""
    text = content.decode("utf-8", errors="replace")
    lines = text.splitlines()
    for i, line in enumerate(lines):
        words = line.split()
        if not words or words[0] not in ("v", "f"):
            continue
        if words[0] == "f":
            if len(words) < 4:
                log.skip(i + 1, "face cut short")
                lines[i] = "# " + line
            continue
        try:
            xyz = [float(w) for w in words[1:4]]
            why = "cut short" if len(xyz) < 3 else "" if all(np.isfinite(xyz)) else "non-finite coordinate"
        except ValueError:
            why = "not numbers"
        if why:
            log.skip(i + 1, f"vertex {why}")
            lines[i] = "v nan nan nan"
            if i == len(lines) - 1 and not text.endswith(("\n", "\r")):
                log.truncate(f"the file ends mid-line (line {i + 1})", line=i + 1)
    return "\n".join(lines).encode()


def _read_mesh(content: bytes, file_type: str, log: ReadLog) -> np.ndarray:
    """Scanner exports as OBJ meshes through trimesh (vertex lines checked first): the vertices or samples on
    the faces."""
    import trimesh

    if file_type == "obj":
        content = _obj_checked(content, log)
    try:
        geom = trimesh.load(io.BytesIO(content), file_type=file_type, process=False)
    except Exception as exc:  # trimesh raises many types on corrupt files
        raise reject(f"unreadable {file_type.upper()} file: {exc}") from None
    parts = list(geom.geometry.values()) if isinstance(geom, trimesh.Scene) else [geom]
    verts, tris, offset = [], [], 0
    for g in parts:
        v = getattr(g, "vertices", None)
        if v is None:
            continue
        v = np.asarray(v, dtype=np.float64)
        if isinstance(g, trimesh.Trimesh) and len(g.faces):
            t = np.asarray(g.faces, dtype=np.int64)
            tris.append(t[np.isfinite(v[t]).all((1, 2))] + offset)  # faces on a vertex left out go too
        verts.append(v)
        offset += len(v)
    if not verts:
        raise reject(f"{file_type.upper()} file holds no vertices")
    return _mesh_points(np.vstack(verts), np.vstack(tris) if tris else None, file_type, log)


def _read_stl(content: bytes, log: ReadLog) -> np.ndarray:
    corners = read_stl(content, log)
    # STL repeats each vertex in every triangle on it: one sample per vertex, as the mesh was scanned
    vertices, index = np.unique(corners.reshape(-1, 3), axis=0, return_inverse=True)
    return _mesh_points(vertices, index.reshape(-1, 3), "stl", log)


def _read_ply(content: bytes, log: ReadLog) -> np.ndarray:
    data = read_ply(content, log, MESH_MIN_VERTICES)
    if data.triangles is None and any(e.name == "face" and e.count for e in ply_elements(content)):
        # a dense mesh's faces are not read, but its vertices are still a mesh's: one sample per position
        vertices = data.vertices[np.isfinite(data.vertices).all(1)]
        first = _first_of_each(vertices)
        return _mesh_points(vertices if first is None else vertices[first], None, "ply", log)
    return _mesh_points(data.vertices, data.triangles, "ply", log)


def _read_las(content: bytes, log: ReadLog) -> tuple[np.ndarray, CrsUnit | str | None]:
    """LAS/LAZ point clouds (laspy; LAZ through its lazrs backend): scaled x, y, z, and the unit the file's CRS
    states (a message instead when it states one that cannot be read). An uncompressed file cut short gives its
    whole point records with a warning; points outside the bounds the header states are reported (a damaged
    scale or offset misplaces every point, silently otherwise)."""
    import laspy

    try:
        with laspy.open(io.BytesIO(content)) as reader:
            header = reader.header
            count = header.point_count
            if not header.are_points_compressed:
                held = max(len(content) - header.offset_to_point_data, 0) // header.point_format.size
                if held < count:
                    log.truncate(f"the header says {count} points but the file holds {held} whole ones (the file "
                                 "was cut?); those were read.", declared=count, read=held)
                    count = held
            if count > MAX_POINTS:  # refused before laspy allocates them (a damaged LAZ count asks for terabytes)
                raise reject(f"the file declares {count:,} points; at most {MAX_POINTS:,} are read (thin the scan, "
                             "e.g. with PDAL or CloudCompare)")
            las = reader.read_points(count) if count else None
    except InputRejected:
        raise
    except Exception as exc:  # laspy raises its own and OS errors on corrupt files
        raise reject(f"unreadable LAS/LAZ file: {str(exc) or type(exc).__name__}") from None
    if las is None or len(las) == 0:
        raise reject("the LAS/LAZ file holds no whole point record" + log.summary())
    scales = np.asarray(header.scales, dtype=np.float64)
    if not (np.isfinite(scales) & (scales != 0)).all():  # x = X * scale + offset: every point at the offset, or NaN
        raise reject(f"the LAS header's scale factors are {', '.join(f'{v:g}' for v in scales)} (x, y, z): "
                     "a scale of 0 or a non-finite one makes every coordinate the offset or NaN; the header is damaged")
    try:
        unit = las_crs_unit(laspy.LasData(header, las))
    except (ValueError, IndexError) as exc:
        unit = f"the file's CRS record cannot be read ({exc})"
    pts = np.column_stack([np.asarray(las.x), np.asarray(las.y), np.asarray(las.z)]).astype(np.float64)
    _check_las_bounds(pts, header, log)
    _refuse_coarse_scale(las, scales, unit)
    return pts, unit


# A LAS record stores x = X * scale + offset with X an integer: a scale of 0.01 m (laspy's and PDAL's default)
# rounds every coordinate to 10 mm, more than a small tube's radius. Refused when the step is at least this many
# metres and it has merged most points into the same positions: no fit can be made of what is left.
COARSE_LAS_STEP_M = 0.002
MERGED_SHARE = 0.5


def _refuse_coarse_scale(las, scales: np.ndarray, unit: CrsUnit | str | None) -> None:
    metres = unit.metres if isinstance(unit, CrsUnit) and not unit.geographic else 1.0  # none stated: metres
    step = float(np.abs(scales).max()) * metres
    if step < COARSE_LAS_STEP_M:
        return
    records = np.column_stack([np.asarray(las.X), np.asarray(las.Y), np.asarray(las.Z)])  # the stored integers
    distinct = len(np.unique(records, axis=0))
    if distinct <= MERGED_SHARE * len(records):
        raise reject(f"the LAS header's scale factors ({', '.join(f'{v:g}' for v in scales)}) round every "
                     f"coordinate to {step * 1000:g} mm steps: the file's {len(records):,} points fall on "
                     f"{distinct:,} distinct positions, too coarse for a tube scan; export it again with a finer "
                     "scale (0.0001 m, or 0.001 ft)")


def _check_las_bounds(pts: np.ndarray, header, log: ReadLog) -> None:
    """A warning when the points' extent leaves the box the header states by more than a few scale steps: the
    writer computed that box from the same records, so a damaged scale or offset shows up here."""
    lo, hi = np.asarray(header.mins, dtype=float), np.asarray(header.maxs, dtype=float)
    if not (np.isfinite(lo).all() and np.isfinite(hi).all()) or (lo == 0).all() and (hi == 0).all():
        return  # a writer that left the box unset
    scales, offsets = np.asarray(header.scales, dtype=float), np.asarray(header.offsets, dtype=float)
    got_lo, got_hi = pts.min(axis=0), pts.max(axis=0)  # scaled integers: always finite
    slack = 4 * np.abs(scales) + 1e-9 * np.maximum(np.abs(lo), np.abs(hi))
    off = (got_lo < lo - slack) | (got_hi > hi + slack)
    with np.errstate(divide="ignore", invalid="ignore"):  # some writers store the box in record units
        raw_lo, raw_hi = (got_lo - offsets) / scales, (got_hi - offsets) / scales
    in_record_units = np.isclose(np.minimum(raw_lo, raw_hi), lo, rtol=1e-9, atol=4) & \
        np.isclose(np.maximum(raw_lo, raw_hi), hi, rtol=1e-9, atol=4)
    if off.any() and not in_record_units.all():
        axes = ", ".join(f"{a}: points {got_lo[i]:.6g} to {got_hi[i]:.6g}, header {lo[i]:.6g} to {hi[i]:.6g}"
                         for i, a in enumerate("xyz") if off[i])
        log.warn(Diagnostic(code="header_bounds_disagree", message=(
            f"LAS file: the points leave the box its header states ({axes}): either that box was written wrongly "
            "or a damaged scale or offset misplaces every point. Check the file against its source."),
            details={"axes": ["xyz"[i] for i in np.flatnonzero(off)], "header_mins": lo.tolist(),
                     "header_maxs": hi.tolist(), "point_mins": got_lo.tolist(), "point_maxs": got_hi.tolist()}))


def _read_e57(source: StoredInput) -> tuple[np.ndarray, bool]:
    """E57 scans (pye57, which reads files on disk only): every scan's cartesian points, each in world
    coordinates (its pose applied), and whether every scan stores them as scaled integers (on a grid)."""
    import pye57
    from pye57 import libe57

    with source.as_file() as path:
        try:
            e57 = pye57.E57(str(path))
            scans = [e57.read_scan(i, ignore_missing_fields=True, transform=True) for i in range(e57.scan_count)]
            scaled = [libe57.StructureNode(e57.get_header(i).node["points"].prototype()).get(axis).type()
                      == libe57.NodeType.E57_SCALED_INTEGER
                      for i, d in enumerate(scans) if "cartesianX" in d for axis in ("cartesianX", "cartesianY",
                                                                                      "cartesianZ")]
        except Exception as exc:  # libE57 raises its own errors on corrupt files
            # its first line says what failed; the rest is its debug dump, naming the server's path of the upload
            raise reject(f"unreadable E57 file: {(str(exc).strip().splitlines() or [type(exc).__name__])[0]}") from None
    parts = [np.column_stack([d["cartesianX"], d["cartesianY"], d["cartesianZ"]]) for d in scans
             if "cartesianX" in d]
    if not parts:
        raise reject("E57 file holds no cartesian points")
    return np.vstack(parts).astype(np.float64), all(scaled)


def _read_npy(content: bytes, log: ReadLog) -> np.ndarray:
    try:
        arr = np.load(io.BytesIO(content), allow_pickle=False)
    except Exception as exc:
        raise reject(f"unreadable NPY file: {exc}") from None
    if arr.ndim == 2 and arr.shape[0] == 3 and arr.shape[1] > 3 and np.issubdtype(arr.dtype, np.number):
        # x, y, z as three rows (saved as pts.T, or from MATLAB's column-major habit): read as three points of
        # N values, they were refused as too few points, naming neither the shape nor the mix-up
        log.warn(Diagnostic(code="npy_transposed", message=(
            f"NPY file: the array has shape {arr.shape}, three rows of {arr.shape[1]} values: read as "
            f"{arr.shape[1]} points (x, y, z in its rows). Save it as (N, 3) to say so."),
            details={"shape": list(arr.shape)}))
        arr = arr.T
    if arr.ndim != 2 or arr.shape[1] < 3 or not np.issubdtype(arr.dtype, np.number):
        raise reject(f"NPY array must be numeric with shape (N, 3), got {arr.shape} {arr.dtype}")
    if arr.shape[1] > 3:
        return _npy_coordinates(arr, log)
    return np.asarray(arr, dtype=np.float64)


def _npy_coordinates(arr: np.ndarray, log: ReadLog) -> np.ndarray:
    """x, y, z of an NPY array of more than three columns, said in a warning naming the columns left out: an NPY
    has no header to say which columns are the coordinates. The first three are (x y z intensity, x y z r g b and
    x y z with normals are how scan tools save clouds), unless the first column counts the rows (0 or 1, 2, 3, ...),
    as a text scan's row number is read: then the next three. Before, the first three columns were read without a
    word, a row number among them."""
    rows = len(arr)
    first = np.asarray(arr[:, 0], dtype=np.float64)
    numbered = rows > 1 and any(np.array_equal(first, np.arange(start, start + rows)) for start in (0, 1))
    start = 1 if numbered and arr.shape[1] >= 4 else 0
    dropped = [k for k in range(arr.shape[1]) if not start <= k < start + 3]
    said = ", ".join(f"column {k + 1}{_span(np.asarray(arr[:, k], dtype=np.float64))}" for k in dropped[:8])
    why = ("its first column counts the rows (a row number): x, y, z read from columns 2 to 4" if start
           else "x, y, z read from its first three columns")
    log.warn(Diagnostic(code="npy_columns_dropped", message=(
        f"NPY file: the array has shape {arr.shape}, {arr.shape[1]} values a point: {why}; left out "
        f"{said}{', ...' if len(dropped) > 8 else ''} (an intensity, colour or normal?). Save it as (N, 3) if "
        "other columns are the coordinates."),
        details={"shape": list(arr.shape), "coordinate_columns": [start + 1, start + 2, start + 3],
                 "dropped_columns": [k + 1 for k in dropped], "row_numbers": bool(start)}))
    return np.asarray(arr[:, start:start + 3], dtype=np.float64)


def _span(values: np.ndarray) -> str:
    finite = values[np.isfinite(values)]
    return f" ({finite.min():.4g} to {finite.max():.4g})" if len(finite) else ""


def _may_repeat(pts: np.ndarray) -> bool:
    """False when no position repeats, told by one sort of a hash of the coordinates' bits; True when two keys are
    equal (the rows themselves then say)."""
    if len(pts) < 2:
        return False
    bits = np.ascontiguousarray(pts, dtype=np.float64).view(np.uint64)  # no copy; a 0.0 repeated as -0.0 is missed
    key = bits[:, 0] * np.uint64(0x9E3779B97F4A7C15)
    key ^= bits[:, 1] * np.uint64(0xC2B2AE3D27D4EB4F)
    key ^= bits[:, 2]
    key.sort()
    return bool((key[1:] == key[:-1]).any())


def _first_of_each(pts: np.ndarray) -> np.ndarray | None:
    """The indices (ascending) of the first sample at each position, None when no position repeats."""
    if not _may_repeat(pts):
        return None
    first = np.sort(np.unique(pts + 0.0, axis=0, return_index=True)[1])
    return first if len(first) < len(pts) else None


# A block pasted again: at least this many consecutive rows equal to an earlier run of as many. A coarse print makes
# single samples coincide; a run of them in the file's order is a copy.
PASTE_ROWS = 4
# Coincidences a print's resolution explains: samples spread evenly at the print's step coincide as often as they lie
# one step apart in one direction, at most this share of the pairs of samples one step apart (1/26 in a volume, about
# 1/8 on a surface; the example scan printed to 0 or 1 decimals at 1-3 times its size and a synthetic 300,000-sample
# scan printed to 1 mm and 0.1 mm give 0.04-0.10)
GRID_SHARE = 0.25
# Repeats of at most this share of the samples are kept unasked: counted twice, they make the sigmas too small by
# at most half of it, and the question costs a neighbour search over every distinct sample
REPEAT_SHARE_IGNORED = 1e-3


def _in_pasted_blocks(position: np.ndarray, counts: np.ndarray) -> np.ndarray:
    """Which rows lie in a run of at least :data:`PASTE_ROWS` consecutive rows equal to an earlier run (each such row
    repeats an earlier one); ``position``: each row's position's number, ``counts``: how many rows each has."""
    rows = np.zeros(len(position), dtype=bool)
    shared = counts[position] > 1
    pair = np.flatnonzero(shared[:-1] & shared[1:])  # a copied run repeats its consecutive pairs too
    if len(pair) < PASTE_ROWS - 1:
        return rows
    _, first = np.unique(np.column_stack([position[pair], position[pair + 1]]), axis=0, return_index=True)
    repeated = np.zeros(len(position) - 1, dtype=bool)
    repeated[pair] = True
    repeated[pair[first]] = False
    edges = np.flatnonzero(np.diff(np.concatenate([[0], repeated.view(np.int8), [0]])))
    for start, stop in zip(edges[::2], edges[1::2]):
        if stop - start >= PASTE_ROWS - 1:
            rows[start:stop + 1] = True
    return rows


# A file held twice in another order (reversed, shuffled, each row doubled) has every position an even number of
# times; a print's coincidences give odd counts among this many positions with a chance of 2**-EVEN_POSITIONS at most.
EVEN_POSITIONS = 64


def _first_halves(position: np.ndarray, counts: np.ndarray) -> np.ndarray:
    """Rows to keep of a file held twice: at each position the first half of its rows (a coarse print's own
    coincidences, held twice too, are kept once each)."""
    order = np.argsort(position, kind="stable")
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    rank = np.arange(len(position)) - np.repeat(starts, counts)
    keep = np.zeros(len(position), dtype=bool)
    keep[order[rank < np.repeat(counts // 2, counts)]] = True
    return keep


def _print_explains(distinct: np.ndarray, counts: np.ndarray) -> bool:
    """Whether the exact repeats of the samples at the ``distinct`` positions (``counts`` samples at each) are what
    the print's resolution gives: the closest distinct samples (Chebyshev distance) are one print step apart, and
    pairs of samples at one place are no more than :data:`GRID_SHARE` of the pairs one step apart. A paste adds
    pairs at one place alone; a coarse print (a dense scan on a 1 mm grid as well) has them in proportion."""
    from scipy.spatial import cKDTree

    if len(distinct) < 2:
        return False
    tree = cKDTree(distinct)
    step = float(tree.query(distinct, k=2, p=np.inf)[0][:, 1].min())
    c = counts.astype(np.float64)
    squares = float(c @ c)
    apart = (tree.count_neighbors(tree, step * (1.0 + 1e-9), p=np.inf, weights=(c, c)) - squares) / 2.0
    together = (squares - float(c.sum())) / 2.0
    predicted = GRID_SHARE * apart
    return together <= predicted + 3.0 * math.sqrt(predicted) + 1.0


def _without_repeats(pts: np.ndarray, ext: str, log: ReadLog, on_grid: bool = False) -> np.ndarray:
    """The samples without a file or scan pasted twice, and a warning saying how many were left out. Pasted, it
    holds every sample twice: fitted as it is, every sigma of the result was √2 too small, and the inspection gave
    verdicts the samples do not carry. A paste is a run of rows repeating an earlier run, or more exact repeats
    than the print's resolution explains. Samples printed coarsely (1 mm) coincide without being copies: each is a
    measurement and is kept. Files of scaled integers (LAS, ``on_grid``: E57 ScaledInteger) store positions on
    their scale's grid, where distinct returns share positions; their coarse scales are refused on their own."""
    if on_grid or not _may_repeat(pts):
        return pts
    distinct, first, position, counts = np.unique(pts + 0.0, axis=0, return_index=True, return_inverse=True,
                                                  return_counts=True)
    position = position.ravel()
    if len(distinct) == len(pts):
        return pts
    if len(distinct) >= EVEN_POSITIONS and not (counts % 2).any():
        keep = _first_halves(position, counts)  # the whole file again, in whatever order (reversed, shuffled)
        loose = 0
    else:
        keep = ~_in_pasted_blocks(position, counts)  # the rows of a copied run are repeats of earlier rows
        loose = int(keep.sum()) - len(distinct)
    if loose > REPEAT_SHARE_IGNORED * len(pts):
        left = np.bincount(position[keep], minlength=len(distinct))
        if not _print_explains(distinct[left > 0], left[left > 0]):
            keep[:] = False
            keep[first] = True
    repeats = int((~keep).sum())
    if repeats == 0:
        return pts
    log.warn(Diagnostic(code="duplicate_points", message=(
        f"{ext[1:].upper()} file: {repeats:,} of its {len(pts):,} samples repeat an earlier one exactly, in runs or "
        "more often than the print's resolution explains (a file or scan pasted twice): each position was read "
        "once. Counted twice, they would have made every sigma of the result too small."),
        details={"repeated": repeats, "samples": len(pts), "kept": len(pts) - repeats}))
    return pts[keep]


E57_METRES = CrsUnit("metre", 1.0, "E57 standard: cartesian coordinates in metres")


class HeaderUnit(CrsUnit):
    """The unit a text file's column header states for x, y, z (``x [m]``, ``x_mm``)."""


# what a text scan may look like to :func:`file_holds`: a table of numbers, or a text mesh or cloud of the formats
# that point lists are exported from under a text extension
POINT_TEXT = ("a CSV table", "an ASCII STL", "a PLY", "a Wavefront OBJ")


def _read_points(source: StoredInput, log: ReadLog) -> tuple[np.ndarray, CrsUnit | str | None, bool]:
    """The samples of a scan file, by its extension (intake accepted only ``UPLOAD_EXTENSIONS``), the unit the
    file or its format states (None: none) and whether it stores them as scaled integers (on a grid)."""
    ext = source.extension
    if ext == ".e57":
        pts, scaled = _read_e57(source)
        return pts, E57_METRES, scaled
    content = source.read()
    if ext in (".las", ".laz"):
        return *_read_las(content, log), True
    pts, stated = _read_unscaled(source, content, log)
    return pts, stated, False


def _read_unscaled(source: StoredInput, content: bytes, log: ReadLog) -> tuple[np.ndarray, CrsUnit | str | None]:
    """The samples and stated unit of a scan file other than E57 and LAS/LAZ."""
    ext = source.extension
    if ext == ".ply":
        stated = stated_ply_unit(content)
        if stated is None or isinstance(stated, str):
            return _read_ply(content, log), stated
        return _read_ply(content, log), HeaderUnit(stated[0], SIZES[stated[0]], stated[1])
    if ext == ".stl":
        return _read_stl(content, log), None
    if ext == ".obj":
        return _read_mesh(content, "obj", log), None
    if ext == ".npy":
        return _read_npy(content, log), None
    holds = file_holds(content[:65536])
    if holds is not None and not holds.startswith(POINT_TEXT):  # a model of another kind, not a list of samples
        raise reject(f"the file holds {holds}, not x, y, z samples of a scan")
    pts, columns = read_text_points(content, log)  # .xyz, .csv, .txt
    if columns.conflict is not None:
        return pts, columns.conflict
    if columns.unit is None:
        return pts, None
    return pts, HeaderUnit(columns.unit, TO_MM[columns.unit] / 1000.0,
                           columns.stated_by or f"the header's columns {', '.join(columns.names or [])}")


def _overridden(ext: str, stated: CrsUnit, file_units: str, metres: float) -> Diagnostic:
    """A warning that ``options.file_units`` contradicts the unit the file states: one of them is a mistake, and
    every length of the result is off by their ratio if it is the option."""
    own = short_name(stated.name, stated.metres)
    return Diagnostic(code="file_unit_overridden", message=(
        f"options.file_units ({file_units}) overrides the unit the {ext[1:].upper()} file states ({own}: "
        f"{stated.evidence}): its coordinates were read as {file_units}, {metres / stated.metres:g} times what the "
        f"file says. Leave file_units out if the file's {own} is right."),
        details={"file_units": file_units, "file_unit": own, "ratio": metres / stated.metres})


def _conversion(ext: str, stated: CrsUnit | str | None, file_units: str | None, target: str,
                stated_units: bool = True) -> tuple[UnitConversion, np.ndarray, list[Diagnostic]]:
    """How the file's coordinates become the request's: the conversion for the report, the factor per axis and
    a warning when the unit was assumed. ``options.file_units`` overrides what the file states; ``stated_units``:
    whether the request's unit was given (else it is the default, mm)."""
    warnings: list[Diagnostic] = []
    to_target = 1000.0 / TO_MM[target]  # metres → the request's unit
    z_name = z_metres = None
    if file_units is not None:
        name, metres, basis = file_units, TO_MM[file_units] / 1000.0, "options.file_units"
        evidence = f"overrides the file's own: {stated.evidence}" if isinstance(stated, CrsUnit) else ""
        if isinstance(stated, CrsUnit) and not stated.geographic and not math.isclose(stated.metres, metres):
            warnings.append(_overridden(ext, stated, file_units, metres))
    elif isinstance(stated, str):
        raise reject(f"{ext[1:].upper()} file: {stated}; set options.file_units to the unit of its coordinates")
    elif stated is not None and stated.geographic:
        raise reject(f"{ext[1:].upper()} file's CRS is geographic ({stated.evidence}): x, y are angles, not lengths; "
                     "a tube scan needs a projected or local CRS (set options.file_units if x, y are lengths)")
    elif stated is not None:
        name, metres, evidence = short_name(stated.name, stated.metres), stated.metres, stated.evidence
        basis = "format" if stated is E57_METRES else "header" if isinstance(stated, HeaderUnit) else "crs"
        if stated.z_metres is not None:
            z_name, z_metres = short_name(stated.z_name, stated.z_metres), stated.z_metres
    elif ext in (".las", ".laz"):
        name, metres, basis, evidence = "m", 1.0, "assumed", "no CRS unit in the file"
        warnings.append(Diagnostic(
            code="file_units_assumed",
            message=f"The {ext[1:].upper()} file states no unit (no CRS with a linear unit): its coordinates were "
            f"read as metres, as scanners write them, and converted to {target} (× {1000.0 / TO_MM[target]:g}). "
            "Set options.file_units if they are in another unit.",
            details={"file_unit": "m", "request_unit": target, "factor": 1000.0 / TO_MM[target]}))
    else:
        said = "units" if stated_units else "default units (none given)"
        conv = UnitConversion(file_unit=target, request_unit=target, factor=1.0, basis="request",
                              evidence=f"{ext[1:].upper()} files state no unit: read in the request's {said}, {target}")
        return conv, np.ones(3), warnings
    factor = metres * to_target
    z_factor = z_metres * to_target if z_metres is not None else None
    conv = UnitConversion(file_unit=name, request_unit=target, factor=factor, z_file_unit=z_name, z_factor=z_factor,
                          basis=basis, evidence=evidence)
    return conv, np.array([factor, factor, z_factor or factor]), warnings


def _default_unit_implausible(ext: str, pts: np.ndarray, target: str) -> list[Diagnostic]:
    """A warning when a file stating no unit, with no unit given either, was read in the default unit and its size
    is implausible for a tube in it but plausible in another: a scan in metres read as millimetres is a thousand
    times too small, and its fit fails or its result is off by that factor. The size (the bounding box's
    diagonal) is known before the fit, so the warning comes with any result and names the unit to give."""
    extent = scan_extent(pts)
    mm = extent * TO_MM[target]
    lo, hi = EXTENT_MM_PLAUSIBLE
    likely = likely_units(mm, EXTENT_MM_PLAUSIBLE, target) if not lo <= mm <= hi else []
    if not likely:
        return []
    return [Diagnostic(
        code="file_units_assumed",
        message=f"The {ext[1:].upper()} file states no unit and none was given: its coordinates were read in "
        f"{target}, the default, but the scan then spans {extent:.4g} {target}, implausible for a tube (expected "
        f"{lo:g} mm to {hi / 1000:g} m); they are likely in {' or '.join(likely)}. Set options.file_units "
        f"(e.g. {likely[0]!r}) to the unit of the file's coordinates.",
        details={"file_unit": target, "request_unit": target, "basis": "default", "extent": extent,
                 "plausible_mm": [lo, hi], "likely_units": likely})]


FORM = FormRules(TubeRequest, units="file")


def parse_upload(source: StoredInput, options: dict | None) -> TubeRequest:
    """Uploaded scan → :class:`TubeRequest` (format from the extension, case-insensitive), with the upload form's
    ``options`` joined to it by the rules of :mod:`plantsolve.solvers.upload_form`: the form's ``units`` is the
    unit of a scan's coordinates where the scan states none (and the result's), and may not contradict a request
    file's."""
    ext = source.extension
    form = read_form(options, FORM)
    units = form.units
    # a file's unit may be one no request is written in (micrometres, an FE or CMM export's): the stored request
    # keeps what the user said, canonically spelled
    file_units = form.read.file_units
    if ext == ".json":
        if file_units is not None:
            raise InputRejected([FieldError(form.at["file_units"], "a JSON file is a request: its points are in "
                                            "its `units` (set units instead)")])
        doc = json_object(source.read(), "JSON must be a request object or a list of [x, y, z]", list_as="points")
        if "points" not in doc:
            keys = ", ".join(sorted(map(str, doc))[:12]) or "nothing"
            raise reject(f"the JSON holds {keys}: not a tube request, which holds `points` (the x, y, z samples of "
                         "the scan); is it a request for another kind?")
        return validated_request(FORM, merged(dict(doc), form, FORM), form)
    target = units or "mm"
    log = ReadLog(ext[1:])
    pts, stated, on_grid = _read_points(source, log)
    if pts.ndim != 2 or pts.shape[1] != 3 or len(pts) == 0:
        raise reject("file holds no 3D points")
    finite = np.isfinite(pts).all(1)
    if not finite.all():  # binary formats (LAS, NPY, E57) have no lines to name: a count
        bad = np.flatnonzero(~finite)
        if len(bad) == len(pts):
            raise reject("every point of the file has a non-finite coordinate")
        log.skip(None, "non-finite coordinate", count=len(bad))
        pts = pts[finite]
    conversion, factors, unit_warnings = _conversion(ext, stated, file_units, target, units is not None)
    if not (factors == 1.0).all():
        pts = pts * factors
    if conversion.basis == "request" and units is None:
        unit_warnings += _default_unit_implausible(ext, pts, target)
    bounded = (np.abs(pts) <= MAX_COORDINATE).all(1)
    if not bounded.all():  # one absurd float of a binary file (LAS, NPY, a PLY cut in its header) is one point
        if not bounded.any():
            raise reject(f"every point of the file has a coordinate beyond {MAX_COORDINATE:g} {target}")
        log.skip(None, f"coordinate beyond {MAX_COORDINATE:g} {target}", count=int((~bounded).sum()))
        pts = pts[bounded]
    pts = _without_repeats(pts, ext, log, on_grid)
    source_report = PointSource(format=ext[1:], points=len(pts), units=conversion, skipped=log.count,
                                skipped_lines=log.lines, truncated=log.truncation is not None,
                                warnings=log.warnings() + unit_warnings)
    body = {"points": points_field(pts), "source": source_report.model_dump()}
    # the request is the reader's making: its paths are the request's, a form option's the form's
    return validated_request(FORM, merged(body, form, FORM), form, elsewhere=lambda error: error)
