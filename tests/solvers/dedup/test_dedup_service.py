"""The dedup kind through the service and the CLI: multipart upload with options, artifacts (the
optimized file, the classes table, the chart), 422s naming the file or the option."""

from __future__ import annotations

import base64
import csv
import io
import json
import tempfile
import zipfile

import ifcopenshell
import pytest

from plantsolve.solvers.base import Cancelled, InputRejected, Solved, StoredInput
from plantsolve.solvers.dedup.synthetic import build_model, ModelSpec
from plantsolve.solvers.dedup import SPEC
from plantsolve.solvers.dedup.solve import solve
from plantsolve.solvers.dedup.upload import parse_upload
from tests.conftest import REPO, run_plantsolve, wait_for

EXAMPLES = REPO / "examples" / "dedup"


def test_zipped_upload_with_options_through_the_api(client):
    content = (EXAMPLES / "tunnel_3rings.ifc").read_bytes()
    archive = io.BytesIO()
    with zipfile.ZipFile(archive, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("tunnel.ifc", content)
    response = client.post("/v1/dedup/jobs", files={"file": ("tunnel.ifczip", archive.getvalue())},
                           data={"options": json.dumps({"sharing": "mapped_item", "tolerance": 1e-4,
                                                            "express_rules": False})})
    assert response.status_code == 202, response.text
    job = wait_for(client, response.json()["id"], timeout=120)
    assert job["status"] == "succeeded", job
    result = client.get(f"/v1/jobs/{job['id']}/result").json()
    assert result["schema"] == "IFC4" and result["tolerance"] == 1e-4 and result["sharing"] == "mapped_item"
    assert result["products_total"] == 24 and result["products_shared"] == 16 and len(result["classes"]) == 8
    assert result["verification"]["schema_valid"] and result["verification"]["semantic_counts_equal"]
    assert result["original_bytes"] == len(content)
    names = {a["name"]: a for a in job["artifacts"]}
    assert set(names) == {"optimized.ifc", "classes.csv", "entity_counts.png"}
    optimized = client.get(names["optimized.ifc"]["url"]).content
    assert len(optimized) == result["optimized_bytes"]
    model = ifcopenshell.file.from_string(optimized.decode())
    assert len(model.by_type("IfcRepresentationMap")) == 8
    rows = list(csv.DictReader(io.StringIO(client.get(names["classes.csv"]["url"]).text)))
    assert len(rows) == 24 and {r["class"] for r in rows} == {str(k) for k in range(1, 9)}
    assert client.get(names["entity_counts.png"]["url"]).content.startswith(b"\x89PNG")


def test_bad_files_are_422_with_the_reason(client):
    good = (EXAMPLES / "tunnel_3rings.ifc").read_bytes()
    cases = {
        "not IFC": b"solid cube\nfacet normal 0 0 1\nendsolid\n",
        "truncated": good[: len(good) // 2],
        "unknown schema": good.replace(b"FILE_SCHEMA(('IFC4'))", b"FILE_SCHEMA(('IFC9'))"),
    }
    for what, content in cases.items():
        problem = client.post("/v1/dedup/jobs", files={"file": ("m.ifc", content)}).json()
        assert problem["status"] == 422 and problem["errors"][0]["loc"][0] == "file", (what, problem)
    zoo2x3 = (EXAMPLES / "zoo_ifc2x3.ifc").read_bytes()
    problem = client.post("/v1/dedup/jobs", files={"file": ("zoo.ifc", zoo2x3)},
                          data={"options": '{"sharing": "product_shape"}'}).json()
    assert problem["status"] == 422 and problem["errors"][0]["loc"] == ["options", "sharing"]
    problem = client.post("/v1/dedup/jobs", json={"file": "not base64!"}).json()
    assert problem["status"] == 422 and problem["errors"][0]["loc"] == ["file"]


def _count_temporaries(monkeypatch) -> list[str]:
    made: list[str] = []
    for name in ("mkdtemp", "mkstemp"):  # TemporaryDirectory and NamedTemporaryFile go through these
        original = getattr(tempfile, name)
        monkeypatch.setattr(tempfile, name, lambda *a, _o=original, _n=name, **k: made.append(_n) or _o(*a, **k))
    return made


def test_a_stored_ifc_is_solved_where_it_lies_and_its_artifacts_come_from_the_solve(monkeypatch):
    made = _count_temporaries(monkeypatch)
    source = StoredInput.from_path(EXAMPLES / "zoo_ifc2x3.ifc")  # as the runner hands a stored upload
    value = SPEC.input_of(SPEC.parse_upload(source, {"express_rules": False}), source)
    SPEC.check_input(value)
    solved = SPEC.solve(value, lambda *a: None)
    assert made == [] and solved.result.verification.schema_valid
    artifacts = {a.name: a.data for a in SPEC.render_artifacts(value, solved)}
    assert list(artifacts) == ["optimized.ifc", "classes.csv", "entity_counts.png"]
    assert artifacts["optimized.ifc"] == solved.files["optimized.ifc"]
    # a result without the file (its proof failed) gets no optimized.ifc: nothing solves again to make one
    assert [a.name for a in SPEC.render_artifacts(value, Solved(solved.result))] == ["classes.csv", "entity_counts.png"]
    assert made == []


def test_a_stored_ifczip_is_extracted_once(monkeypatch, tmp_path):
    archive = tmp_path / "zoo.ifczip"
    with zipfile.ZipFile(archive, "w", zipfile.ZIP_DEFLATED) as z:
        z.write(EXAMPLES / "zoo_ifc2x3.ifc", "zoo.ifc")
    made = _count_temporaries(monkeypatch)
    source = StoredInput.from_path(archive)
    value = SPEC.input_of(SPEC.parse_upload(source, {"express_rules": False}), source)
    SPEC.check_input(value)  # reads the header from the archive's stream, writes nothing
    assert made == []
    solved = SPEC.solve(value, lambda *a: None)
    assert made == ["mkdtemp"] and solved.result.original_bytes == (EXAMPLES / "zoo_ifc2x3.ifc").stat().st_size


def test_cancellation_between_groups():
    source = StoredInput.from_path(EXAMPLES / "tunnel_3rings.ifc", "t.ifc")
    value = SPEC.input_of(parse_upload(source, None), source)
    seen = []

    def progress(fraction, message=""):
        seen.append(message)
        if message.startswith("matching"):
            raise Cancelled()

    with pytest.raises(Cancelled):
        solve(value, progress)
    assert seen[-1].startswith("matching") and not any(m.startswith("sharing") for m in seen)


def test_a_file_without_geometry_is_refused():
    content = build_model(ModelSpec(products=[], containers=1)).to_string().encode()
    source = StoredInput.from_bytes("empty.ifc", content)
    value = SPEC.input_of(parse_upload(source, None), source)
    with pytest.raises(InputRejected, match="no product with geometry"):
        solve(value, lambda *a: None)
    with pytest.raises(InputRejected, match="no product of the model has geometry"):  # and at submission
        SPEC.check_input(value)


def test_json_with_base64_and_the_cli(tmp_path):
    (tmp_path / "zoo.ifc").write_bytes((EXAMPLES / "zoo_ifc2x3.ifc").read_bytes())
    done = run_plantsolve(["solve", "dedup", "zoo.ifc", "-o", "out.json", "--options", '{"express_rules": false}'], tmp_path)
    assert done.returncode == 0, done.stderr
    result = json.loads((tmp_path / "out.json").read_text())
    assert result["schema"] == "IFC2X3" and len(result["classes"]) == 4 and result["sharing"] == "mapped_item"
    assert (tmp_path / "out_artifacts" / "optimized.ifc").stat().st_size == result["optimized_bytes"]
    body = {"filename": "zoo.ifc", "file": base64.b64encode((EXAMPLES / "zoo_ifc2x3.ifc").read_bytes()).decode()}
    request = parse_upload(StoredInput.from_bytes("request.json", json.dumps(body).encode()), {"postpass": False})
    assert request.options.postpass is False and request.file == body["file"]


# ---------------------------------------------------------------- files cut short


def _upload(name: str, content: bytes):
    return parse_upload(StoredInput.from_bytes(name, content), None)


def test_a_step_file_cut_inside_an_entity_is_refused_naming_that_entity():
    good = (EXAMPLES / "tunnel_3rings.ifc").read_bytes()
    lines = good.splitlines(keepends=True)
    cut = b"".join(lines[:len(lines) // 2]) + lines[len(lines) // 2][:25]  # inside that line's entity
    number = lines[len(lines) // 2].split(b"=", 1)[0].decode()
    with pytest.raises(InputRejected) as error:
        _upload("m.ifc", cut)
    (fe,) = error.value.errors
    assert fe.loc == ("file",) and f"stops inside entity {number}" in fe.msg and "truncated" in fe.msg
    with pytest.raises(InputRejected, match="before 'ENDSEC;'"):  # cut between entities: still incomplete
        _upload("m.ifc", good[:good.rfind(b"ENDSEC;")])


def test_what_the_step_format_allows_after_its_end_is_not_a_cut():
    good = (EXAMPLES / "tunnel_3rings.ifc").read_bytes()
    for ending in (b"/* written by the exporter */\r\n", b"\x00" * 64):  # a comment; the padding of a copy
        assert _upload("m.ifc", good + ending).filename == "m.ifc"


def test_a_json_request_cut_short_is_refused_naming_where_it_stops():
    with pytest.raises(InputRejected) as error:
        _upload("m.json", b'{"filename": "m.ifc",\n "options": {"sharing": "mapped')
    (fe,) = error.value.errors
    assert fe.loc == ("file",) and "ends before" in fe.msg and "line 2" in fe.msg
