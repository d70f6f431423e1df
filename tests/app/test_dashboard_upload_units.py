"""The dashboard's upload form offers the result's unit (the request's ``units``) for the kinds whose uploads take
it: before, a tube, polyhedra or rigidity upload from the dashboard always gave its result in the default unit."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest

from plantsolve.app.dashboard_views import UNITS_FROM_UPLOAD_FORM, upload_units
from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.kinds import KINDS
from plantsolve.solvers.tube.synthetic import make_model, surface_samples
from tests.conftest import wait_for

SCAN = "\n".join(" ".join(f"{v:.6f}" for v in p) for p in surface_samples(
    make_model([(40, 0, 60, 12.0), (30, 0, 0, 0)], 4.0), 400, np.random.default_rng(0))).encode()  # mm


def _stop(client, job_id: str) -> None:
    """The job's input is what these tests look at: cancelled rather than solved (a solve takes seconds)."""
    client.post(f"/v1/jobs/{job_id}/cancel")
    wait_for(client, job_id)


def _select(page: str) -> list[str] | None:
    found = re.search(r'<select name="units" id="units">(.*?)</select>', page, re.S)
    return re.findall(r'<option value="([^"]*)"', found.group(1)) if found else None


@pytest.mark.parametrize("kind", sorted(k for k, s in KINDS.items() if s.upload_extensions))
def test_the_upload_form_offers_the_result_unit_where_the_upload_takes_it(client, kind):
    offered = _select(client.get(f"/dashboard/submit/{kind}").text)
    if kind in UNITS_FROM_UPLOAD_FORM:
        assert offered == ["", "mm", "cm", "m", "in", "ft"]  # "": the kind's default, not sent
    else:
        assert offered is None


@pytest.mark.parametrize("kind", sorted(k for k, s in KINDS.items() if ".json" in s.upload_extensions))
def test_the_kinds_offered_are_those_whose_upload_reads_units_from_the_form(kind):
    spec = KINDS[kind]
    field = spec.request_model.model_fields.get("units")
    other = next((u for u in ("m", "mm") if field is not None and u != field.default), "m")
    # a request file that states no unit: the form's is its unit (one the file states may not be contradicted)
    example = {key: value for key, value in spec.example().items() if key != "units"}
    try:
        request = spec.parse_upload(StoredInput.from_bytes("x.json", json.dumps(example).encode()), {"units": other})
        taken = getattr(request, "units", None) == other
    except InputRejected:
        taken = False
    assert taken or kind not in UNITS_FROM_UPLOAD_FORM  # the dashboard offers the choice only where it is taken
    assert (kind in UNITS_FROM_UPLOAD_FORM) == (upload_units(spec) is not None)


def test_a_tube_upload_with_a_chosen_unit_is_requested_and_read_in_it(client):
    response = client.post("/dashboard/submit/tube", follow_redirects=False,
                           data={"source": "upload", "options": '{"seed": 0}', "option_defaults": '{"seed": 0}',
                                 "units": "m"},
                           files={"file": ("scan.xyz", SCAN, "text/plain")})
    assert response.status_code == 303
    job_id = response.headers["location"].rsplit("/", 1)[-1]
    assert client.get(f"/v1/jobs/{job_id}/input").json()["options"] == {"units": "m"}
    request = KINDS["tube"].parse_upload(StoredInput.from_bytes("scan.xyz", SCAN), {"units": "m"})
    assert request.units == "m" and request.source.units.factor == 1.0  # the file read in the unit chosen
    _stop(client, job_id)
    # the choice reads the file too where it states no unit: the form says so, not "result unit" alone
    label = re.search(r"<label>Unit \(the request's <code>units</code>(.*?)<select", client.get(
        "/dashboard/submit/tube").text, re.S)
    assert label and "the file's coordinates where the file states no unit" in label.group(1) and "file_units" in label.group(1)


def test_the_default_is_not_sent_and_a_contradicting_unit_is_refused_naming_both(client):
    left = client.post("/dashboard/submit/tube", follow_redirects=False,
                       data={"source": "upload", "options": '{"seed": 0}', "option_defaults": '{"seed": 0}',
                             "units": ""}, files={"file": ("scan.xyz", SCAN, "text/plain")})
    job_id = left.headers["location"].rsplit("/", 1)[-1]
    assert client.get(f"/v1/jobs/{job_id}/input").json()["options"] is None
    _stop(client, job_id)
    refused = client.post("/dashboard/submit/tube", data={"source": "upload", "options": '{"units": "mm"}',
                                                          "units": "in"},
                          files={"file": ("scan.xyz", SCAN, "text/plain")})
    assert refused.status_code == 422 and "<code>/units</code>" in refused.text
    assert "&#39;in&#39;" in refused.text and "&#39;mm&#39;" in refused.text
    assert _select(refused.text) and 'value="in" selected' in refused.text  # the choice stays on the form
