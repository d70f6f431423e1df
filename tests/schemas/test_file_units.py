"""One vocabulary of length units: a request's ``units`` (mm, cm, m, in, ft) and a file's, which may also be
micrometres (an FE or CMM export's). A field whose consumer converts micrometres (a tube scan's ``file_units``: its
reader's table has them) takes them in every spelling; every other unit field refuses them with a 422 naming the
field and saying why, never a silent default."""

from __future__ import annotations

import json
import tempfile
import typing
from pathlib import Path

import pytest
from fastapi.testclient import TestClient
from pydantic import BaseModel, ValidationError

from plantsolve.app.main import create_app
from plantsolve.schemas.common import FILE_UNIT_SPELLINGS, MICROMETRE_SPELLINGS, UNIT_SPELLINGS, FileUnitName, \
    UnitName
from plantsolve.schemas.polyhedra import PolyhedraOptions
from plantsolve.schemas.tube import TubeOptions
from plantsolve.solvers import length_units
from plantsolve.solvers.kinds import load_kinds
from tests.conftest import service_settings

REPO = Path(__file__).resolve().parents[2]
MICROMETRES = ["um", "µm", "μm", "UM", "Microns", " micrometre "]


def test_the_schemas_vocabulary_is_the_readers():
    """The readers' table of sizes and spellings has exactly the units and words the schema names."""
    assert dict(length_units.SPELLINGS) == dict(FILE_UNIT_SPELLINGS)
    assert set(length_units.SIZES) == set(typing.get_args(FileUnitName)) == set(FILE_UNIT_SPELLINGS)
    assert set(typing.get_args(UnitName)) == set(UNIT_SPELLINGS) == set(length_units.METRES)
    assert length_units.SIZES["um"] == 1e-6 and "µm" in MICROMETRE_SPELLINGS and "μm" in MICROMETRE_SPELLINGS


@pytest.mark.parametrize("word", MICROMETRES)
def test_a_tube_scans_file_units_take_micrometres_in_every_spelling(word):
    assert TubeOptions.model_validate({"file_units": word}).file_units == "um"  # main: a literal_error
    assert TubeOptions.model_validate_json(json.dumps({"file_units": word}), strict=True).file_units == "um"


@pytest.mark.parametrize("word", MICROMETRES)
def test_a_requests_units_refuse_micrometres_saying_so(word):
    with pytest.raises(ValidationError) as refused:
        PolyhedraOptions.model_validate({"file_units": word})
    (error,) = refused.value.errors()
    assert error["loc"] == ("file_units",) and "micrometres" in error["msg"], error


def _flat(annotation) -> list:
    return [annotation] + [a for arg in typing.get_args(annotation) for a in _flat(arg)]


def _unit_fields(model: type[BaseModel], seen: set, prefix: str = "") -> list[tuple[str, tuple]]:
    """(field path, its enum) of every length-unit field of ``model`` and the models it holds."""
    if model in seen:
        return []
    seen.add(model)
    found = []
    for name, field in model.model_fields.items():
        for part in _flat(field.annotation):
            if part in (UnitName, FileUnitName):
                found.append((f"{prefix}{name}", typing.get_args(part)))
            if isinstance(part, type) and issubclass(part, BaseModel):
                found += _unit_fields(part, seen, f"{prefix}{name}.")
    return found


def test_only_a_tube_scans_file_units_take_micrometres():
    """Every kind's request: the unit fields whose enum has 'um' are the ones whose readers convert it."""
    fields = {f"{kind}.{path}": names for kind, spec in load_kinds(()).items()
              for path, names in _unit_fields(spec.request_model, set())}
    assert {"polyhedra.options.file_units", "polyhedra.units", "flowmeter.units", "tube.units"} <= set(fields)
    assert {path for path, names in fields.items() if "um" in names} == {"tube.options.file_units"}


@pytest.fixture(scope="module")
def client():
    with tempfile.TemporaryDirectory() as folder:
        with TestClient(create_app(service_settings(Path(folder)), run_jobs=False)) as test_client:
            yield test_client


def _file(path: str) -> tuple[str, bytes]:
    return Path(path).name, (REPO / path).read_bytes()


@pytest.mark.parametrize(("kind", "upload", "option"), [
    ("polyhedra", "examples/polyhedra/two_offices.idf", "file_units"),
    ("polyhedra", "examples/polyhedra/two_offices.idf", "units"),
    ("tube", "examples/tube/scan.xyz", "units"),
])
@pytest.mark.parametrize("word", ["um", "µm"])
def test_an_upload_forms_micrometres_where_they_are_not_read_are_a_422_naming_the_option(client, kind, upload,
                                                                                         option, word):
    response = client.post(f"/v1/{kind}/jobs", files={"file": _file(upload)},
                           data={"options": json.dumps({option: word})})
    assert response.status_code == 422, response.text
    (error,) = response.json()["errors"]
    # polyhedra lays the form's units over the request's (its loc is the request's units)
    assert error["loc"] in (["options", option], [option] if option == "units" else None), error


@pytest.mark.parametrize("body", [
    ("flowmeter", "examples/flowmeter/meter.json"), ("rigidity", "examples/rigidity/four_bar_and_door.json"),
    ("alignment", "examples/alignment/ladder.json"), ("polyhedra", "examples/polyhedra/gable_house.json"),
    ("tube", "examples/tube/scan_request.json")])
def test_a_json_bodys_units_in_micrometres_are_a_422_saying_so(client, body):
    kind, path = body
    document = {**json.loads((REPO / path).read_text()), "units": "µm"}
    response = client.post(f"/v1/{kind}/jobs", json=document)
    assert response.status_code == 422, response.text
    (error,) = response.json()["errors"]
    assert error["loc"] == ["units"] and "micrometres" in error["msg"], error


def test_a_tube_json_bodys_file_units_in_micrometres_are_taken_and_warned_ignored_by_the_solver(client):
    """A JSON body states its own units; file_units there is ignored with a warning, as for any other unit (main:
    a 422 for 'um' alone)."""
    document = json.loads((REPO / "examples/tube/scan_request.json").read_text())
    document["options"] = {**document.get("options", {}), "file_units": "µm"}
    response = client.post("/v1/tube/jobs", json=document)
    assert response.status_code == 202, response.text
    assert client.get(response.headers["Location"] + "/input").json()["options"]["file_units"] == "µm"


@pytest.mark.parametrize("word", ["um", "µm", "μm", "microns"])
def test_a_tube_scan_in_micrometres_is_converted_by_the_factor(client, word):
    """Through the API (accepted) and the reader (the number): a micrometre is a thousandth of the request's mm."""
    from plantsolve.solvers.base import StoredInput

    response = client.post("/v1/tube/jobs", files={"file": _file("examples/tube/scan.xyz")},
                           data={"options": json.dumps({"file_units": word})})
    assert response.status_code == 202, response.text
    name, data = _file("examples/tube/scan.xyz")
    spec = load_kinds(())["tube"]
    plain = spec.parse_upload(StoredInput.from_bytes(name, data), None)
    micro = spec.parse_upload(StoredInput.from_bytes(name, data), {"file_units": word})
    assert micro.source.units.file_unit == "um" and micro.source.units.factor == pytest.approx(1e-3)
    assert micro.points[0] == pytest.approx([v * 1e-3 for v in plain.points[0]])
