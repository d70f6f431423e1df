"""The upload's ``units`` option for a table (CSV, sheet, pyCycle map), as a GasTurb map takes it: a CSV whose
header gives no unit was refused with 'options/units: Extra inputs are not permitted', while the refusal of its
``result_units`` asked for ``units.pressure``, which an upload had no way to give."""

from __future__ import annotations

import json

import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.perfmap.upload import parse_upload
from plantsolve.solvers.perfmap.validation import load
from tests.conftest import wait_for
from tests.solvers.perfmap.conftest import DATA

N3 = (DATA / "n3_fan_map.csv").read_text()
NCP01 = (DATA / "pycycle" / "ncp01.py").read_text()
HEADER = "theta,phi,flow,pressure,efficiency"


def _load(text: str, options: dict, name: str = "rig.csv"):
    source = StoredInput.from_bytes(name, text.encode())
    return load(parse_upload(source, {"map": False, **options}), source)


def test_units_a_header_leaves_out_are_read_from_the_option_and_convert():
    loaded = _load(N3, {"units": {"flow": "lbm/s", "pressure": "bar"},
                        "result_units": {"flow": "kg/s", "pressure": "kPa"}})
    first = loaded.internal.positions[0]
    assert (loaded.units.flow, loaded.units.pressure) == ("kg/s", "kPa")
    assert first.flow[0] == pytest.approx(1104.338 * 0.45359237, rel=1e-12)
    assert first.pressure[0] == pytest.approx(107.6, rel=1e-12)
    said = [w for w in loaded.request.upload_warnings if w.code == "upload_units_option"]
    assert [w.details["quantity"] for w in said] == ["flow", "pressure"]


def test_an_option_agreeing_with_the_header_changes_nothing():
    loaded = _load(N3.replace(HEADER, "theta,phi,flow [kg/s],pressure,efficiency"), {"units": {"flow": "kg s^-1"}})
    assert loaded.units.flow == "kg/s" and loaded.internal.positions[0].flow[0] == 1104.338


@pytest.mark.parametrize("text, name, option, stated", [
    (N3.replace(HEADER, "theta,phi,flow [kg/s],pressure,efficiency"), "rig.csv", {"flow": "lbm/s"}, "'kg/s'"),
    (NCP01, "ncp01.py", {"flow": "kg/s"}, "'lbm/s'"),  # pyCycle states its WcMap unit
    (NCP01, "ncp01.py", {"pressure": "kPa"}, "'1'"),  # and its PRmap is a ratio
])
def test_an_option_contradicting_the_files_unit_is_refused_naming_both(text, name, option, stated):
    with pytest.raises(InputRejected) as refused:
        _load(text, {"units": option}, name)
    (error,) = refused.value.errors
    (quantity, unit), = option.items()
    assert error.loc == ("options", "units", quantity) and repr(unit) in error.msg and stated in error.msg


@pytest.mark.parametrize("option, needle", [({"efficiency": "%"}, "efficiency [%]"), ({"flow": "Nm3/h"}, "standard"),
                                            ({"flow": 5}, "unit text")])
def test_an_option_the_table_cannot_take_is_refused_naming_it(option, needle):
    with pytest.raises(InputRejected) as refused:
        _load(N3, {"units": option})
    (error,) = refused.value.errors
    assert error.loc == ("options", "units", *option) and needle in error.msg


def test_through_the_api_the_option_reaches_the_result(tmp_path):
    from fastapi.testclient import TestClient

    from plantsolve.app.main import create_app
    from tests.conftest import service_settings

    with TestClient(create_app(service_settings(tmp_path))) as client:
        options = {"map": False, "units": {"flow": "kg/s", "pressure": "bar"}, "result_units": {"pressure": "kPa"}}
        submitted = client.post("/v1/perfmap/jobs", files={"file": ("rig.csv", N3.encode())},
                                data={"options": json.dumps(options)})
        assert submitted.status_code == 202, submitted.text
        job = wait_for(client, submitted.json()["id"], timeout=180)
        assert job["status"] == "succeeded", job
        result = client.get(f"/v1/jobs/{job['id']}/result").json()
        assert result["units"]["flow"] == "kg/s" and result["units"]["pressure"] == "kPa"
        refused = client.post("/v1/perfmap/jobs", files={"file": ("rig.csv", N3.replace(
            HEADER, "theta,phi,flow [lbm/s],pressure,efficiency").encode())},
            data={"options": json.dumps({"units": {"flow": "kg/s"}})})
        assert refused.status_code == 422
        (error,) = refused.json()["errors"]
        assert error["pointer"] == "/options/units/flow" and "'lbm/s'" in error["msg"]


def test_a_pasted_paragraph_as_a_unit_is_refused_at_once_naming_the_option():
    """A unit option of 100,000 characters took the upload's whole CPU budget (8 s) before it was refused unnamed;
    it is refused by its length, before pint and the casings are tried on it."""
    from plantsolve.solvers.base import InputRejected, StoredInput
    from plantsolve.solvers.perfmap.upload import parse_upload

    table = b"flow,pressure ratio,efficiency,speed\n1,1.2,0.8,1000\n2,1.3,0.82,1000\n3,1.25,0.81,1000\n"
    with pytest.raises(InputRejected) as refused:
        parse_upload(StoredInput.from_bytes("rig.csv", table), {"units": {"flow": "k" * 100_000}})
    assert "options.units.flow" in str(refused.value) and "100,000 characters" in str(refused.value)
