"""Hostile or malformed IFC input is refused with what is wrong with it: an .ifczip that inflates past the
limit (declared or counted), a file that is STEP but no IFC model (points only, no IfcProject)."""

from __future__ import annotations

import io
import zipfile

import ifcopenshell
import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.dedup import SPEC, source
from tests.solvers.dedup.support import assert_round_trip

HEADER = ("ISO-10303-21;\nHEADER;\nFILE_DESCRIPTION(('ViewDefinition [CoordinationView]'),'2;1');\n"
          "FILE_NAME('p.ifc','2026-01-01T00:00:00',(''),(''),'','','');\nFILE_SCHEMA(('IFC4'));\nENDSEC;\nDATA;\n")


def points_only(n: int) -> bytes:
    body = "".join(f"#{i}=IFCCARTESIANPOINT(({i}.,0.,0.));\n" for i in range(1, n + 1))
    return (HEADER + body + "ENDSEC;\nEND-ISO-10303-21;\n").encode()


def _input(name: str, content: bytes):
    stored = StoredInput.from_bytes(name, content)
    return SPEC.input_of(SPEC.parse_upload(stored, None), stored)


def test_a_step_file_without_an_ifc_project_says_so():
    with pytest.raises(InputRejected) as refused:
        SPEC.solve(_input("points.ifc", points_only(500)), lambda f, m="": None)
    (error,) = refused.value.errors
    assert error.loc == ("file",) and "no IfcProject" in error.msg and "500 IfcCartesianPoint" in error.msg


def test_a_file_of_points_only_is_refused_at_submission_naming_what_it_holds(client):
    """It was accepted (202) and the job failed at stage input; the intake's scan of entity names refuses it."""
    refused = client.post("/v1/dedup/jobs", files={"file": ("points.ifc", points_only(300), "application/x-step")})
    assert refused.status_code == 422 and refused.headers["content-type"].startswith("application/problem+json")
    (error,) = refused.json()["errors"]
    assert error["loc"] == ["file"] and "has no product" in error["msg"] and "300 IfcCartesianPoint" in error["msg"]


def _zipped(content: bytes) -> bytes:
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", zipfile.ZIP_DEFLATED) as archive:
        archive.writestr("model.ifc", content)
    return buffer.getvalue()


def test_an_ifczip_declaring_more_than_the_limit_is_refused_before_inflating(monkeypatch):
    monkeypatch.setattr(source, "MAX_IFC_INFLATED", 4096)
    with pytest.raises(InputRejected) as refused:
        _input("model.ifczip", _zipped(points_only(1000))).header()
    assert "inflates to" in refused.value.errors[0].msg and refused.value.errors[0].loc == ("file",)


def test_inflated_bytes_are_counted_whatever_the_zip_declares(monkeypatch):
    monkeypatch.setattr(source, "MAX_IFC_INFLATED", 1000)
    counted = source.InflationCounter(io.BytesIO(b"x" * 5000))  # a member whose declared size lied
    assert len(counted.read(600)) == 600
    with pytest.raises(InputRejected, match="more than 1,000 bytes"):
        counted.read(600)


def test_an_ifczip_damaged_in_its_compressed_bytes_or_cut_short_says_so_naming_the_file():
    """Corrupt deflate data raised zlib.error out of the reader (a 422 calling the file malformed; in a worker an
    EOFError from a cut stream counts as an infrastructure failure and is retried), and a cut archive was called
    'not a zip archive'. Both now say the archive is damaged or cut short."""
    archive = bytearray(_zipped(points_only(2000)))
    start = 30 + len("model.ifc")  # the local header, then the compressed bytes
    archive[start + 40:start + 48] = b"\xff" * 8
    for name, content in (("damaged.ifczip", bytes(archive)), ("cut.ifczip", _zipped(points_only(2000))[:3000])):
        with pytest.raises(InputRejected) as refused:
            _input(name, content).header()
        (error,) = refused.value.errors
        assert error.loc == ("file",) and "damaged or cut short" in error.msg, error.msg


def test_an_ifc_behind_an_editors_byte_order_mark_is_optimized_like_the_file_without_it():
    """The header check let a UTF-8 byte-order mark before 'ISO-10303-21;' through (202), then IfcOpenShell's parser
    stopped at it and the job failed at stage input ('Unable to parse IFC SPF header'). The solve now reads the text
    after the mark, in an .ifc and inside an .ifczip."""
    from pathlib import Path

    plain = (Path(__file__).parents[3] / "examples" / "dedup" / "tunnel_3rings.ifc").read_bytes()
    marked = b"\xef\xbb\xbf" + plain
    solved = [SPEC.solve(_input(name, content), lambda *a, **k: None).result
              for name, content in (("t.ifc", plain), ("t.ifc", marked), ("t.ifczip", _zipped(marked)))]
    assert {(r.products_shared, r.optimized_bytes) for r in solved} == {(solved[0].products_shared,
                                                                        solved[0].optimized_bytes)}
    assert solved[0].products_shared > 0


@pytest.mark.parametrize("value", [b"1e308", b"1,5"])
def test_a_product_with_an_absurd_or_unreadable_point_is_left_unchanged_not_the_job_failed(value):
    """One IfcCartesianPoint of the example tunnel written as 1e308 (or as '1,5', which IfcOpenShell reads as no
    number) passed the intake and failed the job at stage solver ('data must be finite' in the matching's k-d
    tree; an inhomogeneous array in the explicit reader). Now that product is left unchanged and reported."""
    import re
    from pathlib import Path

    plain = (Path(__file__).parents[3] / "examples" / "dedup" / "tunnel_3rings.ifc").read_bytes()
    numbers = list(re.finditer(rb"(?<![\w.])-?\d+\.\d+", plain))
    middle = numbers[len(numbers) // 2]
    poisoned = plain[:middle.start()] + value + plain[middle.end():]
    whole, damaged = (SPEC.solve(_input("t.ifc", content), lambda *a, **k: None).result for content in (plain, poisoned))
    left = next(w for w in damaged.report.warnings if w.code == "left_unchanged")
    assert left.details["count"] == 1 and left.details["products"][0]["reason"] == "geometry could not be processed"
    assert damaged.products_total == whole.products_total and damaged.products_shared == whole.products_shared - 1


def test_a_geometry_naming_an_entity_the_file_lacks_leaves_its_products_unchanged_not_the_job_failed():
    """The example zoo (IFC2X3) with one number written '-inf' leaves a reference the parser cannot resolve: the
    geometry kernel refused the whole batch of products (RuntimeError 'unresolved reference') and the job failed
    at stage solver. Now each product is tessellated alone, the broken ones are left unchanged and reported, and
    an optimized file the proof cannot verify is not offered."""
    import re
    from pathlib import Path

    plain = (Path(__file__).parents[3] / "examples" / "dedup" / "zoo_ifc2x3.ifc").read_bytes()
    numbers = list(re.finditer(rb"(?<![\w.])-?\d+\.\d+(?:[eE][-+]?\d+)?", plain))
    middle = numbers[len(numbers) // 2]
    damaged = plain[:middle.start()] + b"-inf" + plain[middle.end():]
    result = SPEC.solve(_input("zoo.ifc", damaged), lambda *a, **k: None).result
    codes = {w.code: w for w in result.report.warnings}
    assert codes["left_unchanged"].details["count"] >= 1 and result.products_total > 0


def _renumbered(plain: bytes, number: int) -> bytes:
    """The file with its middle instance renumbered to ``number`` (its definition and every reference)."""
    import re

    ids = [int(m.group(1)) for m in re.finditer(rb"^#(\d+)=", plain, re.M)]
    return re.sub(rb"#%d\b" % ids[len(ids) // 2], b"#%d" % number, plain)


def test_an_instance_numbered_in_the_billions_costs_no_mask_that_long():
    """One instance of the example tunnel numbered #2,000,000,000: masks indexed by instance number took 2 GB
    (and #2,147,483,647 then failed the job at stage solver, IfcOpenShell's by_id overflowing). Now it is optimized
    like the file numbered from 1, in bounded memory."""
    import tracemalloc
    from pathlib import Path

    plain = (Path(__file__).parents[3] / "examples" / "dedup" / "tunnel_3rings.ifc").read_bytes()
    whole = SPEC.solve(_input("t.ifc", plain), lambda *a, **k: None).result
    renumbered = _renumbered(plain, 2_000_000_000)
    tracemalloc.start()
    try:
        solved = SPEC.solve(_input("t.ifc", renumbered), lambda *a, **k: None)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 100 * 2**20, peak
    sparse = solved.result
    assert (sparse.products_shared, sparse.products_total) == (whole.products_shared, whole.products_total) != (0, 0)
    # the optimized file read back as a user would: every product's world geometry and the rooted instances kept
    assert_round_trip(ifcopenshell.file.from_string(renumbered.decode()), solved)


def test_instance_numbers_beyond_what_ifcopenshell_addresses_are_refused_naming_the_instance():
    from pathlib import Path

    plain = (Path(__file__).parents[3] / "examples" / "dedup" / "tunnel_3rings.ifc").read_bytes()
    with pytest.raises(InputRejected) as refused:
        SPEC.solve(_input("t.ifc", _renumbered(plain, 2_147_483_646)), lambda *a, **k: None)
    (error,) = refused.value.errors
    assert error.loc == ("file",) and "#2147483646" in error.msg
