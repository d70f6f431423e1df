"""Truncation is a warning: each tube point reader keeps what is usable of a damaged file and says what it left
out (line numbers, first few and a count) in report.warnings; the file is refused (422 on ``file``) only when
nothing usable is left. A succeeded job with skipped input never looks clean."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.tube.scan import TubeScan
from plantsolve.solvers.tube.solve import solve
from plantsolve.solvers.tube.upload import parse_upload
from plantsolve.solvers.tube.model import tube_mesh_arrays
from plantsolve.solvers.tube.synthetic import make_model, surface_samples

ROWS = [(40, 0, 60, 12.0), (25, 45, 90, 16.0), (30, 0, 0, 0)]


def cloud(n=3000, seed=0):
    return surface_samples(make_model(ROWS, 4.0), n, np.random.default_rng(seed))


def xyz_lines(pts, cols=3) -> list[str]:
    extra = " 200 100 50" if cols == 6 else ""
    return [f"{x:.6f} {y:.6f} {z:.6f}{extra}" for x, y, z in pts]


def warning(req, code):
    return next(w for w in req.source.warnings if w.code == code)


def codes(req) -> list[str]:
    return [w.code for w in req.source.warnings]


def test_a_truncated_binary_ply_keeps_its_complete_vertices_and_the_job_warns():
    pts = cloud()
    data = trimesh.PointCloud(pts).export(file_type="ply", encoding="binary")
    cut = data[: len(data) - 12 * 1000 - 5]  # 1000 vertices and 5 bytes of one more gone
    req = parse_upload(StoredInput.from_bytes("scan.ply", cut), None)
    got = TubeScan(req).points
    assert len(got) == 1999 and np.allclose(got, pts[:1999], atol=1e-4)
    w = warning(req, "file_truncated")
    assert "1999 of 3000 vertex" in w.message and req.source.truncated
    res = solve(req).result
    assert res.report.status == "warning" and "file_truncated" in [x.code for x in res.report.warnings]
    assert res.pipe_radius == pytest.approx(4.0, rel=0.02)


def test_an_ascii_ply_cut_mid_line_and_with_a_nan_vertex_names_the_lines():
    pts = cloud()
    text = trimesh.PointCloud(pts).export(file_type="ply", encoding="ascii").decode()
    lines = text.splitlines()
    header = lines.index("end_header") + 1
    lines[header + 10] = "1.0 nan 2.0"  # vertex 11, on line header + 11
    lines = lines[: header + 2500]
    lines[-1] = lines[-1][:8]  # the last line cut after 8 characters
    req = parse_upload(StoredInput.from_bytes("scan.ply", "\n".join(lines).encode()), None)
    assert len(TubeScan(req).points) == 2498
    skipped = warning(req, "records_skipped")
    assert skipped.details["lines"] == [header + 11, header + 2500]
    assert f"line {header + 2500}" in warning(req, "file_truncated").message
    assert req.source.skipped == 2 and req.source.skipped_lines == [header + 11, header + 2500]


def test_a_sparse_ply_mesh_cut_in_its_faces_samples_the_faces_it_has():
    coarse = trimesh.creation.cylinder(radius=4.0, height=80.0, sections=16)
    data = coarse.export(file_type="ply", encoding="binary")
    cut = data[: len(data) - 13 * 10]  # ten of its triangles (1 + 3·4 bytes each) gone
    req = parse_upload(StoredInput.from_bytes("scan.ply", cut), None)
    pts = TubeScan(req).points
    assert len(pts) == 20_000 and np.hypot(pts[:, 0], pts[:, 1]).max() <= 4.0 + 1e-9
    w = warning(req, "file_truncated")
    assert w.details == {"element": "face", "read": len(coarse.faces) - 10, "declared": len(coarse.faces)}


@pytest.mark.parametrize("ext", ["xyz", "csv", "txt"])
def test_text_points_with_a_cut_a_nan_and_an_unreadable_line_keep_the_rest(ext):
    pts = cloud()
    lines = ["x y z"] + xyz_lines(pts)
    lines[100] = "1.5 2.5"  # cut: two columns
    lines[200] = "1.0 NaN 3.0"
    lines[300] = "1.0 abc 3.0"
    if ext == "csv":
        lines = [ln.replace(" ", ",") for ln in lines]
    req = parse_upload(StoredInput.from_bytes(f"scan.{ext}", "\n".join(lines).encode()), None)
    assert len(TubeScan(req).points) == 2997
    w = warning(req, "records_skipped")
    assert w.details["lines"] == [101, 201, 301] and w.details["count"] == 3
    assert "lines 101, 201, 301" in w.message
    assert set(w.details["reasons"]) == {"fewer than 3 coordinates", "non-finite coordinate", "not numbers"}


def test_a_row_with_fewer_columns_than_the_others_is_cut_and_a_file_ending_mid_line_says_so():
    pts = cloud()
    lines = xyz_lines(pts, cols=6)
    lines[-1] = lines[-1].rsplit(" ", 2)[0]  # the last line lost its last two columns, and its newline
    req = parse_upload(StoredInput.from_bytes("scan.xyz", "\n".join(lines).encode()), None)
    assert len(TubeScan(req).points) == 2999
    assert warning(req, "records_skipped").details["lines"] == [3000]
    assert "cut short (4 of 6 columns)" in warning(req, "records_skipped").message
    assert "line 3000" in warning(req, "file_truncated").message


def test_many_skipped_lines_list_the_first_ten_and_count_the_rest():
    pts = cloud()
    lines = xyz_lines(pts)
    for k in range(0, 250, 10):
        lines[k] = "nan nan nan"
    req = parse_upload(StoredInput.from_bytes("scan.xyz", "\n".join(lines).encode()), None)
    w = warning(req, "records_skipped")
    assert w.details["count"] == 25 and w.details["lines"] == list(range(1, 101, 10))
    assert "and 15 more" in w.message


def test_an_obj_with_bad_vertex_lines_drops_them_and_the_faces_on_them():
    verts, faces = tube_mesh_arrays(make_model(ROWS, 4.0))
    text = trimesh.Trimesh(verts, faces, process=False).export(file_type="obj")
    lines = text.splitlines()
    vlines = [i for i, ln in enumerate(lines) if ln.startswith("v ")]
    lines[vlines[5]] = "v 1.0 2.0"  # cut
    lines[vlines[7]] = "v 1.0 nan 2.0"
    req = parse_upload(StoredInput.from_bytes("scan.obj", "\n".join(lines).encode()), None)
    pts = TubeScan(req).points
    assert np.isfinite(pts).all()
    w = warning(req, "records_skipped")
    assert w.details["lines"] == [vlines[5] + 1, vlines[7] + 1]
    if len(verts) >= 2000:  # a dense scan mesh: its vertices, less the two
        assert len(pts) == len(verts) - 2
    res = solve(req).result
    assert "records_skipped" in [x.code for x in res.report.warnings] and res.report.status == "warning"
    assert res.report.details["source"]["skipped"] == 2


def test_a_clean_file_reports_no_skipped_records():
    req = parse_upload(StoredInput.from_bytes("scan.xyz", "\n".join(xyz_lines(cloud())).encode() + b"\n"), None)
    assert req.source.skipped == 0 and not req.source.truncated and codes(req) == []


@pytest.mark.parametrize("name,data,needle", [
    ("scan.xyz", b"x y z\n1 2\n3 nan 4\n", "lines 2, 3"),
    ("scan.ply", (b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                  b"end_header\n1 2\n"), "ends after 1 of 3 vertex records"),
    ("scan.ply", (b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                  b"property float z\nend_header\n\x00\x00"), "ends after 0 of 3 vertex records"),
    ("scan.obj", b"v 1 2\nv nan 1 2\n", "lines 1, 2"),
])
def test_nothing_usable_left_is_refused_naming_file_and_what_was_wrong(name, data, needle):
    with pytest.raises(InputRejected) as e:
        parse_upload(StoredInput.from_bytes(name, data), None)
    assert e.value.errors[0].loc == ("file",) and needle in e.value.errors[0].msg, e.value.errors[0].msg


def test_a_file_cut_inside_its_last_number_is_caught_by_the_decimals_of_its_rows():
    pts = cloud()
    text = "\n".join(xyz_lines(pts))[:-4]  # '…-12.345678' → '…-12.345', no newline
    req = parse_upload(StoredInput.from_bytes("scan.xyz", text.encode()), None)
    assert len(TubeScan(req).points) == 2999
    assert warning(req, "records_skipped").details["lines"] == [3000] and req.source.truncated
    whole = parse_upload(StoredInput.from_bytes("scan.xyz", "\n".join(xyz_lines(pts)).encode()), None)
    assert whole.source.skipped == 0 and not whole.source.truncated  # no newline at the end alone is no cut


@pytest.mark.parametrize("encoding", ["binary", "ascii"])
def test_an_stl_cut_short_keeps_its_complete_triangles(encoding):
    verts, faces = tube_mesh_arrays(make_model(ROWS, 4.0))
    mesh = trimesh.Trimesh(verts, faces, process=False)
    if encoding == "binary":
        data = trimesh.exchange.stl.export_stl(mesh)
        cut = data[: len(data) - 50 * 100 - 20]  # 100 triangles and 20 bytes of one more gone
        kept = len(faces) - 101
    else:
        lines = trimesh.exchange.stl.export_stl_ascii(mesh).splitlines()
        ends = [i for i, ln in enumerate(lines) if ln.strip() == "endfacet"]
        lines[ends[0] - 2] = "vertex 1.0 nan 2.0"  # the first facet's second corner unreadable
        cut_at = ends[-101] + 4  # inside the facet after the 100th last
        cut = "\n".join(lines[:cut_at]).encode()
        kept = len(faces) - 101  # the 100 facets after the cut, and the one with the NaN
    req = parse_upload(StoredInput.from_bytes("scan.stl", cut), None)
    pts = TubeScan(req).points
    assert len(pts) == len(verts) and np.isfinite(pts).all()  # a dense mesh: its vertices (each on kept triangles)
    w = warning(req, "file_truncated")
    assert (f"{kept} of {len(faces)} triangles" in w.message) if encoding == "binary" else "inside a facet" in w.message
    if encoding == "ascii":
        assert warning(req, "records_skipped").details["lines"][0] == ends[0] - 1
    assert solve(req).result.pipe_radius == pytest.approx(4.0, rel=0.02)


def test_npy_rows_with_nan_are_left_out_and_counted():
    import io

    pts = cloud()
    pts[[7, 70]] = np.nan
    buffer = io.BytesIO()
    np.save(buffer, pts)
    req = parse_upload(StoredInput.from_bytes("scan.npy", buffer.getvalue()), None)
    assert len(TubeScan(req).points) == 2998
    w = warning(req, "records_skipped")
    assert w.details["count"] == 2 and w.details["reasons"] == {"non-finite coordinate": 2}


@pytest.mark.parametrize("encode", [
    lambda t: t.encode("utf-16"), lambda t: t.encode("utf-16-le"), lambda t: t.encode("utf-16-be"),
    lambda t: b"\xef\xbb\xbf" + t.encode()])
def test_an_ascii_stl_saved_as_utf16_or_behind_a_mark_is_read_as_text_not_as_binary_garbage(encode):
    """Re-saved by a Windows editor, an ASCII STL no longer started with 'solid' byte for byte: it was read as a
    binary STL 'cut short' whose triangles were its characters taken for floats, and accepted (or refused naming
    points[0] beyond 1e12)."""
    verts, faces = tube_mesh_arrays(make_model(ROWS, 4.0))
    text = trimesh.exchange.stl.export_stl_ascii(trimesh.Trimesh(verts, faces, process=False))
    plain = TubeScan(parse_upload(StoredInput.from_bytes("scan.stl", text.encode()), None)).points
    req = parse_upload(StoredInput.from_bytes("scan.stl", encode(text)), None)
    assert np.array_equal(TubeScan(req).points, plain) and req.source.skipped == 0 and not req.source.truncated


def test_one_absurd_coordinate_costs_its_point_not_the_file():
    """A coordinate past the schema's 1e12 bound (1e308 in a text line, 3e20 in a binary STL facet, 1e300 in an NPY
    row) refused the whole file naming points[i]; now its line, triangle or row is skipped and reported."""
    import io

    pts = cloud()
    lines = xyz_lines(pts)
    lines[10] = "1e308 0 0"
    req = parse_upload(StoredInput.from_bytes("scan.xyz", ("\n".join(lines) + "\n").encode()), None)
    assert len(TubeScan(req).points) == 2999 and warning(req, "records_skipped").details["lines"] == [11]
    verts, faces = tube_mesh_arrays(make_model(ROWS, 4.0))
    data = bytearray(trimesh.exchange.stl.export_stl(trimesh.Trimesh(verts, faces, process=False)))
    data[84 + 50 * 5 + 16:84 + 50 * 5 + 20] = np.float32(3e20).tobytes()  # facet 6's first corner, its y
    req = parse_upload(StoredInput.from_bytes("scan.stl", bytes(data)), None)
    assert req.source.skipped == 1 and np.abs(TubeScan(req).points).max() < 1e3
    pts[[7]] = 1e300
    buffer = io.BytesIO()
    np.save(buffer, pts)
    req = parse_upload(StoredInput.from_bytes("scan.npy", buffer.getvalue()), None)
    assert len(TubeScan(req).points) == 2999 and req.source.skipped == 1


def test_a_line_of_stray_bytes_costs_its_line_not_the_file():
    """One line of bytes that are not UTF-8 refused the whole point list ('text file is not UTF-8')."""
    lines = [s.encode() for s in xyz_lines(cloud())]
    lines[20] = b"\xff\xfe\x01 garbage"
    req = parse_upload(StoredInput.from_bytes("scan.xyz", b"\n".join(lines) + b"\n"), None)
    assert len(TubeScan(req).points) == 2999 and warning(req, "records_skipped").details["lines"] == [21]
