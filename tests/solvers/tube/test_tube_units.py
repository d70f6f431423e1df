"""Units are never silently wrong: each point-file format's unit convention is applied and stated.

LAS/LAZ written by laspy in metres (as scanners write them) with no CRS, with a WKT CRS in feet (WKT1 and
WKT2, compound with a vertical unit of its own) and with GeoTIFF unit keys; E57 in metres; PLY/XYZ in the
request's unit; ``options.file_units`` over all of them; and a warning when the fitted pipe radius is
implausible for the unit (the mix-up named)."""

from __future__ import annotations

import io
import json
import tempfile
from pathlib import Path

import numpy as np
import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.tube.scan import TubeScan
from plantsolve.solvers.tube.solve import solve
from plantsolve.solvers.tube.upload import parse_upload
from plantsolve.solvers.tube.synthetic import make_model, surface_samples

ROWS = [(40, 0, 60, 12.0), (25, 45, 90, 16.0), (30, 0, 0, 0)]  # mm; pipe radius 4 mm
FT, M = 304.8, 1000.0  # mm per unit
US_SURVEY_FOOT_M = 1200.0 / 3937.0

WKT1_FEET = ('PROJCS["NAD83 / Texas North Central (ftUS-like, foot)",GEOGCS["NAD83",DATUM["North_American_Datum_1983",'
             'SPHEROID["GRS 1980",6378137,298.257222101]],PRIMEM["Greenwich",0],UNIT["degree",0.0174532925199433]],'
             'PROJECTION["Lambert_Conformal_Conic_2SP"],PARAMETER["false_easting",1968500],'
             'UNIT["foot",0.3048,AUTHORITY["EPSG","9002"]],AXIS["Easting",EAST],AXIS["Northing",NORTH]]')
WKT2_US_FEET = ('PROJCRS["NAD83 / California zone 3 (ftUS)",BASEGEOGCRS["NAD83",DATUM["North American Datum 1983",'
                'ELLIPSOID["GRS 1980",6378137,298.257222101,LENGTHUNIT["metre",1]]],'
                'PRIMEM["Greenwich",0,ANGLEUNIT["degree",0.0174532925199433]]],'
                'CONVERSION["SPCS83 California zone 3 (US survey foot)",METHOD["Lambert Conic Conformal (2SP)"],'
                'PARAMETER["False easting",6561666.667,LENGTHUNIT["US survey foot",0.304800609601219]]],'
                'CS[Cartesian,2],AXIS["easting (X)",east,ORDER[1],LENGTHUNIT["US survey foot",0.304800609601219]],'
                'AXIS["northing (Y)",north,ORDER[2],LENGTHUNIT["US survey foot",0.304800609601219]]]')
WKT1_COMPOUND = ('COMPD_CS["local metres + height in feet",LOCAL_CS["plant grid",LOCAL_DATUM["plant",0],'
                 'UNIT["metre",1],AXIS["X",EAST],AXIS["Y",NORTH]],'
                 'VERT_CS["height",VERT_DATUM["local",2005],UNIT["foot",0.3048],AXIS["Up",UP]]]')
WKT1_GEOGRAPHIC = ('GEOGCS["WGS 84",DATUM["WGS_1984",SPHEROID["WGS 84",6378137,298.257223563]],PRIMEM["Greenwich",0],'
                   'UNIT["degree",0.0174532925199433]]')


def cloud_mm(n=3000, seed=0):
    return surface_samples(make_model(ROWS, 4.0), n, np.random.default_rng(seed))


def las_bytes(pts: np.ndarray, wkt: str | None = None, geokeys: dict[int, int] | None = None,
              compress: bool = False, evlr: bool = False) -> bytes:
    """A LAS 1.4 (or LAZ, through lazrs) file of the points, with a WKT CRS record (a VLR, or an EVLR after the
    points) or GeoTIFF keys."""
    import laspy
    from laspy.vlrs.known import GeoKeyDirectoryVlr, GeoKeyEntryStruct, WktCoordinateSystemVlr
    from laspy.vlrs.vlrlist import VLRList

    header = laspy.LasHeader(point_format=6, version="1.4")
    header.scales = np.array([1e-7, 1e-7, 1e-7])
    header.offsets = pts.min(axis=0)
    if wkt is not None:
        header.global_encoding.wkt = True
        if not evlr:
            header.vlrs.append(WktCoordinateSystemVlr(wkt))
    if geokeys is not None:
        vlr = GeoKeyDirectoryVlr()
        vlr.geo_keys_header.key_directory_version = 1
        vlr.geo_keys_header.number_of_keys = len(geokeys)
        vlr.geo_keys = []
        for key, value in geokeys.items():
            entry = GeoKeyEntryStruct()
            entry.id, entry.tiff_tag_location, entry.count, entry.value_offset = key, 0, 1, value
            vlr.geo_keys.append(entry)
        header.vlrs.append(vlr)
    las = laspy.LasData(header)
    las.x, las.y, las.z = pts[:, 0], pts[:, 1], pts[:, 2]
    if wkt is not None and evlr:
        las.evlrs = VLRList([WktCoordinateSystemVlr(wkt)])
    buf = io.BytesIO()
    if compress:
        las.write(buf, do_compress=True, laz_backend=laspy.LazBackend.Lazrs)
    else:
        las.write(buf)
    return buf.getvalue()


def codes(report) -> list[str]:
    return [w.code for w in report.warnings]


@pytest.mark.parametrize("ext", ["las", "laz"])
def test_las_in_metres_without_crs_is_read_as_metres_and_solves_in_mm(ext):
    pts = cloud_mm()
    data = las_bytes(pts / M, compress=ext == "laz")
    if ext == "laz":
        assert data[:4] == b"LASF" and b"laszip encoded" in data[:2000]  # really compressed (LASzip VLR)
    req = parse_upload(StoredInput.from_bytes(f"scan.{ext}", data), None)
    assert np.allclose(TubeScan(req).points, pts, atol=1e-3)
    res = solve(req).result
    assert res.units == "mm" and res.pipe_radius == pytest.approx(4.0, rel=0.01)
    assert [round(r.length) for r in res.lra] in ([40, 25, 30], [30, 25, 40])
    assert res.lra[0].bend_radius == pytest.approx(16.0, rel=0.02) or res.lra[0].bend_radius == pytest.approx(12.0, rel=0.02)
    # the conversion is stated, and that it was assumed is a warning
    assert "file_units_assumed" in codes(res.report) and res.report.status == "warning"
    assert "implausible_pipe_radius" not in codes(res.report)
    units = res.report.details["source"]["units"]
    assert units["file_unit"] == "m" and units["factor"] == pytest.approx(1000.0) and units["basis"] == "assumed"


@pytest.mark.parametrize("ext", ["las", "laz"])
def test_las_with_a_feet_crs_is_converted_from_feet(ext):
    pts = cloud_mm()
    data = las_bytes(pts / FT, wkt=WKT1_FEET, compress=ext == "laz")
    req = parse_upload(StoredInput.from_bytes(f"scan.{ext}", data), {"pipe_radius": 4.0})
    assert np.allclose(TubeScan(req).points, pts, atol=1e-3)
    assert req.source.units.file_unit == "ft" and req.source.units.basis == "crs"
    assert req.source.units.factor == pytest.approx(FT) and 'UNIT["foot", 0.3048]' in req.source.units.evidence
    assert req.source.warnings == []  # stated by the file: nothing assumed
    if ext == "laz":
        res = solve(req).result
        assert res.pipe_radius == 4.0 and sorted(round(r.length) for r in res.lra) == [25, 30, 40]
        assert res.report.details["source"]["units"]["file_unit"] == "ft"
        assert "file_units_assumed" not in codes(res.report)


@pytest.mark.parametrize("wkt,geokeys,xy_mm,z_mm,name,evlr", [
    (WKT2_US_FEET, None, US_SURVEY_FOOT_M * 1000, US_SURVEY_FOOT_M * 1000, "us_ft", False),
    (WKT1_COMPOUND, None, M, FT, "m", False),
    (WKT1_FEET, None, FT, FT, "ft", True),
    (None, {1024: 1, 3076: 9002}, FT, FT, "ft", False),
    (None, {1024: 1, 3076: 9003}, US_SURVEY_FOOT_M * 1000, US_SURVEY_FOOT_M * 1000, "us_ft", False),
    (None, {1024: 1, 3076: 9001, 4099: 9002}, M, FT, "m", False),
])
def test_crs_units_from_wkt2_compound_wkt_evlr_and_geotiff_keys(wkt, geokeys, xy_mm, z_mm, name, evlr):
    pts = cloud_mm()
    data = las_bytes(pts / [xy_mm, xy_mm, z_mm], wkt=wkt, geokeys=geokeys, evlr=evlr)
    req = parse_upload(StoredInput.from_bytes("scan.las", data), None)
    assert np.allclose(TubeScan(req).points, pts, atol=1e-3)
    u = req.source.units
    assert u.file_unit == name and u.factor == pytest.approx(xy_mm) and u.basis == "crs"
    assert (u.z_factor is None) == (xy_mm == z_mm) and (u.z_factor or u.factor) == pytest.approx(z_mm)


def test_request_unit_other_than_mm_gets_the_right_factor():
    pts = cloud_mm()
    req = parse_upload(StoredInput.from_bytes("scan.las", las_bytes(pts / FT, wkt=WKT1_FEET)), {"units": "in"})
    assert np.allclose(TubeScan(req).points, pts / 25.4, atol=1e-4)
    assert req.units == "in" and req.source.units.factor == pytest.approx(12.0)


def test_file_units_overrides_the_files_own_unit_and_says_so():
    pts = cloud_mm()
    data = las_bytes(pts / M, wkt=WKT1_FEET)  # the CRS record is wrong: the numbers are metres
    req = parse_upload(StoredInput.from_bytes("scan.las", data), {"file_units": "m"})
    assert np.allclose(TubeScan(req).points, pts, atol=1e-3)
    u = req.source.units
    assert u.basis == "options.file_units" and u.file_unit == "m" and "overrides" in u.evidence and "foot" in u.evidence
    ply_req = parse_upload(StoredInput.from_bytes("scan.xyz", "\n".join(" ".join(map(str, p)) for p in pts / 10)
                                                  .encode()), {"file_units": "cm"})
    assert np.allclose(TubeScan(ply_req).points, pts, atol=1e-6) and ply_req.source.units.factor == 10.0


def test_geographic_crs_is_refused_naming_file_unless_file_units_says_otherwise():
    pts = cloud_mm() / M
    data = las_bytes(pts, wkt=WKT1_GEOGRAPHIC)
    with pytest.raises(InputRejected) as e:
        parse_upload(StoredInput.from_bytes("scan.las", data), None)
    assert e.value.errors[0].loc == ("file",) and "geographic" in e.value.errors[0].msg
    assert parse_upload(StoredInput.from_bytes("scan.las", data), {"file_units": "m"}).source.units.factor == 1000.0


def test_formats_without_a_unit_are_read_in_the_request_unit_and_say_so():
    pts = cloud_mm()
    text = "\n".join(" ".join(map(str, p)) for p in pts).encode()
    req = parse_upload(StoredInput.from_bytes("scan.xyz", text), {"units": "mm"})
    u = req.source.units
    assert u.basis == "request" and u.factor == 1.0 and u.file_unit == "mm" and req.source.warnings == []


def test_e57_states_metres_by_its_standard():
    import pye57

    pts = cloud_mm() / M
    with tempfile.NamedTemporaryFile(suffix=".e57") as handle:
        writer = pye57.E57(handle.name, mode="w")
        writer.write_scan_raw({"cartesianX": pts[:, 0], "cartesianY": pts[:, 1], "cartesianZ": pts[:, 2]})
        writer.close()
        data = Path(handle.name).read_bytes()
    req = parse_upload(StoredInput.from_bytes("scan.e57", data), {"units": "cm"})
    assert np.allclose(TubeScan(req).points, pts * 100.0, atol=1e-6)
    assert req.source.units.basis == "format" and req.source.units.factor == pytest.approx(100.0)
    assert "E57" in req.source.units.evidence


def test_wkt_reader_finds_the_linear_unit_not_the_angular_or_parameter_ones():
    from plantsolve.solvers.tube.las_units import wkt_unit

    assert wkt_unit(WKT1_FEET).metres == 0.3048
    assert wkt_unit(WKT2_US_FEET).name == "US survey foot"
    assert wkt_unit(WKT1_GEOGRAPHIC).geographic
    compound = wkt_unit(WKT1_COMPOUND)
    assert (compound.metres, compound.z_metres) == (1.0, 0.3048)
    with pytest.raises(ValueError):
        wkt_unit('PROJCS["cut", UNIT["metre",1]')


def test_metres_read_as_millimetres_give_an_implausible_radius_warning():
    pts = cloud_mm() * 12.5 / M  # a 50 mm pipe radius in metres, but the request (and the file, which states nothing) says mm
    text = "\n".join(" ".join(f"{v:.9f}" for v in p) for p in pts).encode()
    res = solve(parse_upload(StoredInput.from_bytes("scan.xyz", text), None)).result
    assert res.pipe_radius == pytest.approx(0.05, rel=0.01)
    warning = next(w for w in res.report.warnings if w.code == "implausible_pipe_radius")
    assert res.report.status == "warning"
    assert warning.details["likely_units"][0] == "m" and "likely in m" in warning.message


def test_millimetres_read_as_metres_give_an_implausible_radius_warning():
    from plantsolve.schemas.tube import TubeRequest

    res = solve(TubeRequest(points=cloud_mm().tolist(), units="m")).result  # a 4 m pipe radius
    warning = next(w for w in res.report.warnings if w.code == "implausible_pipe_radius")
    assert warning.details["pipe_radius_mm"] == pytest.approx(4000, rel=0.01)
    assert warning.details["likely_units"][0] == "mm"


def test_file_units_in_a_json_request_is_ignored_with_a_warning_and_refused_for_a_json_upload():
    from plantsolve.schemas.tube import TubeRequest

    body = {"points": cloud_mm().tolist(), "options": {"file_units": "m", "pipe_radius": 4.0}}
    res = solve(TubeRequest.model_validate(body)).result
    assert "file_units_ignored" in codes(res.report) and res.pipe_radius == 4.0
    with pytest.raises(InputRejected) as e:
        parse_upload(StoredInput.from_bytes("scan.json", json.dumps(body).encode()), {"file_units": "m"})
    assert e.value.errors[0].loc == ("options", "file_units")


def test_a_scan_too_small_for_its_unit_is_fitted_and_its_likely_unit_named():
    from plantsolve.schemas.tube import TubeRequest

    # a 4 mm tube in metres, read as millimetres: 0.1 mm long; the local fits are unit-free, so the tube is found
    # (it failed to give a radius before) and the result says which unit its numbers are likely in
    result = solve(TubeRequest(points=(cloud_mm() / M).tolist())).result
    assert result.pipe_radius == pytest.approx(0.004, rel=0.01)
    (warning,) = [w for w in result.report.warnings if w.code == "implausible_pipe_radius"]
    assert "likely in m" in warning.message and "file_units" in warning.message


def test_a_fit_that_fails_on_a_scan_too_small_for_its_unit_names_the_likely_unit():
    from plantsolve.schemas.tube import TubeRequest
    from plantsolve.solvers.base import SolverError

    rng = np.random.default_rng(1)  # a 0.1 mm patch of a plane: no tube at any unit
    patch = np.c_[rng.uniform(0, 0.1, (3000, 2)), rng.normal(0, 1e-6, 3000)]
    with pytest.raises(SolverError) as e:
        solve(TubeRequest(points=patch.tolist()))
    assert "likely in m" in e.value.message and "file_units" in e.value.message
    assert e.value.details["extent"] == pytest.approx(0.1414, rel=0.01)


def _contradiction(name: str, data: bytes, file_units: str):
    req = parse_upload(StoredInput.from_bytes(name, data), {"file_units": file_units})
    return next((w for w in req.source.warnings if w.code == "file_unit_overridden"), None)


def test_file_units_that_contradict_the_unit_the_file_states_are_a_warning_with_the_ratio():
    pts = cloud_mm()
    header_m = ("x [m],y [m],z [m]\n" + "\n".join(",".join(f"{v:.7f}" for v in p) for p in pts / M)).encode()
    # before: the option won without a word, every length 1000 times the header's
    warning = _contradiction("scan.csv", header_m, "mm")
    assert warning is not None and warning.details == {"file_units": "mm", "file_unit": "m", "ratio": 0.001}
    assert "options.file_units (mm) overrides the unit the CSV file states (m: the header's columns" in warning.message
    warning = _contradiction("scan.las", las_bytes(pts / M, wkt=WKT1_FEET), "m")
    assert warning is not None and warning.details["ratio"] == pytest.approx(1 / 0.3048)
    assert _contradiction("scan.csv", header_m, "m") is None  # the option says what the file says
    assert _contradiction("scan.xyz", "\n".join(" ".join(map(str, p)) for p in pts).encode(), "cm") is None
