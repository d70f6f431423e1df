"""A JSON request body's ``units`` by any of its spellings ('MM', 'Millimetres', ' IN ', 'Feet'), as uploads read them:
before, every kind with ``units`` refused all but the canonical symbols with a 422 (the enum); 'Mm' is refused naming
both of its readings (SI's megametre, millimetres with a slipped shift key), and the OpenAPI enum is unchanged."""

from __future__ import annotations

import json

import pytest

from plantsolve.solvers.kinds import KINDS
from tests.conftest import wait_for

CANONICAL = ["mm", "cm", "m", "in", "ft"]
KINDS_WITH_UNITS = sorted(kind for kind, spec in KINDS.items()  # those whose request's units is a length unit
                          if spec.request_model.model_json_schema()["properties"].get("units", {}).get("enum")
                          == CANONICAL)
SPELLED = {"MM": "mm", "Millimetres": "mm", " IN ": "in", "Feet": "ft", "Centimeters": "cm", "METRE": "m"}


def test_the_kinds_with_a_length_unit_are_found():
    assert set(KINDS_WITH_UNITS) >= {"alignment", "flowmeter", "polyhedra", "rigidity", "tube"}


@pytest.mark.parametrize("kind", KINDS_WITH_UNITS)
def test_a_json_body_names_its_unit_by_any_spelling(client, kind):
    spec = KINDS[kind]
    for word, unit in SPELLED.items():
        body = {**spec.example(), "units": word}
        request = spec.request_model.model_validate_json(json.dumps(body), strict=True)  # as the intake reads it
        assert request.units == unit
        response = client.post(f"/v1/{kind}/jobs", json=body)
        assert response.status_code == 202, (word, response.text)
        client.post(f"/v1/jobs/{response.json()['id']}/cancel")  # accepted is the point; solving takes seconds
        wait_for(client, response.json()["id"], timeout=60)


@pytest.mark.parametrize("kind, word, unit", [("polyhedra", "Feet", "ft"), ("polyhedra", "MM", "mm")])
def test_a_spelled_unit_is_the_result_unit(client, kind, word, unit):
    job = client.post(f"/v1/{kind}/jobs", json={**KINDS[kind].example(), "units": word}).json()["id"]
    assert wait_for(client, job, timeout=60)["status"] == "succeeded"
    assert client.get(f"/v1/jobs/{job}/result").json()["units"] == unit


@pytest.mark.parametrize("kind", KINDS_WITH_UNITS)
def test_mm_with_a_capital_m_is_refused_naming_both_readings_and_an_unknown_unit_by_the_enum(client, kind):
    for word, names in (("Mm", ("megametre", "millimetres")), ("furlong", ("'mm', 'cm', 'm', 'in' or 'ft'",))):
        response = client.post(f"/v1/{kind}/jobs", json={**KINDS[kind].example(), "units": word})
        assert response.status_code == 422, response.text
        error = response.json()["errors"][0]
        assert error["loc"] == ["units"] and all(name in error["msg"] for name in names), error


def test_the_openapi_enum_lists_the_canonical_units_only(client):
    schemas = client.get("/openapi.json").json()["components"]["schemas"]
    enums = {json.dumps(found["enum"]) for schema in schemas.values()
             for found in [schema.get("properties", {}).get("units", {})] if "enum" in found}
    assert enums == {json.dumps(CANONICAL)}
