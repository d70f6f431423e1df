"""Every kind's upload reader joins the form's ``options`` to its file by one rule set
(:mod:`plantsolve.solvers.upload_form`), and each refusal names the value where the user wrote it: the form's
``options.units``, ``options.<option>`` or ``options.options.<option>``, a request file's ``file.units`` and
``file.options.<option>``.

Before, the readers merged in five ways: a bad form ``units`` was ``units`` (polyhedra, rigidity) or ``file.units``
(alignment, a file without units), a tube file's own bad option ``options.x``; an option the form and the file gave
differently was the form's without a word, a form ``units`` contradicting a tube or rigidity request file relabelled
the file's numbers, and a form ``options`` that is no object raised a TypeError in three kinds."""

from __future__ import annotations

import base64
import copy
import json
from pathlib import Path

import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.kinds import load_kinds

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
KINDS = load_kinds(())


def _json(path: str) -> dict:
    return json.loads((EXAMPLES / path).read_text())


DEDUP = {"filename": "tunnel.ifc", "options": {"tolerance": 0.5},
         "file": base64.b64encode((EXAMPLES / "dedup/tunnel_3rings.ifc").read_bytes()).decode()}
# each kind's request file, an option of it given a value, another value it takes, and a file its reader makes a
# request of (None: the kind reads request files only)
SETUP = {
    "alignment": (_json("alignment/ladder.json"), "position_tolerance", 1.0, 2.0, "alignment/ladder.pcf"),
    "tube": (_json("tube/scan_request.json"), "damping", 0.8, 0.5, "tube/scan.xyz"),
    "perfmap": (_json("perfmap/n3_fan_map.json"), "surge_margin", 0.1, 0.2, "perfmap/n3_fan_map.csv"),
    "polyhedra": (_json("polyhedra/gable_house.json"), "merge_tolerance", 1e-6, 1e-5, "polyhedra/two_offices.idf"),
    "flowmeter": (_json("flowmeter/meter.json"), "tolerance", 0.002, 0.003, None),
    "rigidity": (_json("rigidity/four_bar_and_door.json"), "contact_tolerance", 0.01, 0.02,
                 "rigidity/hinged_wall.ldr"),
    "dedup": (DEDUP, "tolerance", 0.5, 0.7, "dedup/tunnel_3rings.ifc"),
}
LENGTH_UNITS = ["alignment", "tube", "polyhedra", "flowmeter", "rigidity"]


def _file(kind: str, **changes) -> dict:
    """The kind's request file, its option set to the first value, with ``changes`` (None: the key left out)."""
    body, option, value, _, _ = SETUP[kind]
    body = copy.deepcopy(body)
    body["options"] = {**body.get("options", {}), option: value}
    body.update(changes)
    return {key: v for key, v in body.items() if v is not None}


def _upload(kind: str, body: dict | None, form, name: str | None = None):
    if body is None:
        path = SETUP[kind][4]
        return KINDS[kind].parse_upload(StoredInput.from_bytes(Path(path).name, (EXAMPLES / path).read_bytes()), form)
    return KINDS[kind].parse_upload(StoredInput.from_bytes(name or "request.json", json.dumps(body).encode()), form)


def _refused(kind: str, body: dict | None, form) -> list:
    with pytest.raises(InputRejected) as refused:
        _upload(kind, body, form)
    return refused.value.errors


# a PCF takes no units (tests/solvers/alignment); flowmeter reads request files only
WITH_UNITS = [(kind, read) for kind in LENGTH_UNITS for read in (False, True)
              if not read or kind not in ("alignment", "flowmeter")]


@pytest.mark.parametrize(("kind", "read"), WITH_UNITS, ids=[f"{k}-{'read' if r else 'json'}" for k, r in WITH_UNITS])
@pytest.mark.parametrize("units", [5, "furlong", "Mm"])
def test_a_bad_form_units_is_named_options_units(kind, read, units):
    """``read``: the file is one the reader makes a request of; else a request file stating no units."""
    (error,) = _refused(kind, None if read else _file(kind, units=None), {"units": units})
    assert error.loc == ("options", "units"), error
    if units == "furlong":  # the units and their names, as a JSON body's refusal lists them
        assert "'furlong'" in error.msg and "mm, cm, m, in, ft" in error.msg, error.msg


@pytest.mark.parametrize("kind", sorted(SETUP))
def test_a_request_files_bad_option_is_named_in_the_file(kind):
    option = SETUP[kind][1]
    for form in (None, {"seed": 1} if kind == "tube" else None):
        errors = _refused(kind, _file(kind, options={**_file(kind)["options"], option: "abc"}), form)
        assert [e.loc for e in errors] == [("file", "options", option)], errors


@pytest.mark.parametrize("kind", sorted(SETUP))
def test_an_option_the_form_and_the_file_give_differently_is_refused_naming_both(kind):
    _, option, value, other, _ = SETUP[kind]
    (error,) = _refused(kind, _file(kind), {option: other})
    assert error.loc == ("options", option), error
    assert f"file.options.{option}" in error.msg and repr(value) in error.msg and repr(other) in error.msg


@pytest.mark.parametrize("kind", sorted(SETUP))
def test_an_option_the_form_and_the_file_give_alike_is_taken(kind):
    _, option, value, _, _ = SETUP[kind]
    request = _upload(kind, _file(kind), {option: str(value)})  # a form may type a number as text
    assert getattr(request.options, option) == value


@pytest.mark.parametrize("kind", sorted(SETUP))
def test_a_request_files_bad_option_is_refused_though_the_form_gives_it(kind):
    _, option, value, _, _ = SETUP[kind]
    errors = _refused(kind, _file(kind, options={option: "abc"}), {option: value})
    assert [e.loc for e in errors] == [("file", "options", option)], errors


@pytest.mark.parametrize("kind", ["alignment", "tube", "flowmeter", "rigidity"])
def test_a_form_units_contradicting_a_request_files_is_refused_naming_both(kind):
    (error,) = _refused(kind, _file(kind, units="in"), {"units": "mm"})
    assert error.loc == ("options", "units") and "file.units" in error.msg and "'in'" in error.msg, error


@pytest.mark.parametrize("kind", ["alignment", "tube", "flowmeter", "rigidity"])
def test_a_form_units_is_a_request_files_that_states_none_and_may_repeat_one(kind):
    assert _upload(kind, _file(kind, units=None), {"units": "IN"}).units == "in"
    assert _upload(kind, _file(kind, units="in"), {"units": "inches"}).units == "in"


def test_a_polyhedra_files_lengths_are_converted_into_the_forms_units():
    body = _file("polyhedra", units="in")
    request = _upload("polyhedra", body, {"units": "mm"})
    assert request.units == "mm"
    corner = body["faces"][0]["loops"][0][2]  # the floor's corner at 8 by 10 (inches here)
    assert request.faces[0].loops[0][2] == pytest.approx([25.4 * v for v in corner])


@pytest.mark.parametrize("kind", sorted(SETUP))
def test_a_nested_form_option_is_named_where_it_was_written(kind):
    option = SETUP[kind][1]
    for body in (_file(kind), None) if SETUP[kind][4] else (_file(kind),):
        errors = _refused(kind, body, {"options": {option: "abc"}})
        assert [e.loc for e in errors] == [("options", "options", option)], errors


@pytest.mark.parametrize("kind", sorted(SETUP))
def test_a_nested_form_option_is_taken_and_one_given_flat_too_must_agree(kind):
    _, option, value, other, _ = SETUP[kind]
    body = _file(kind, options={})
    assert getattr(_upload(kind, body, {"options": {option: other}}).options, option) == other
    (error,) = _refused(kind, body, {option: value, "options": {option: other}})
    assert error.loc == ("options", "options", option) and f"options.{option}" in error.msg, error


@pytest.mark.parametrize("kind", sorted(SETUP))
@pytest.mark.parametrize("form", [[1], "tolerance=1", 3])
def test_form_options_that_are_no_object_are_refused_naming_options(kind, form):
    (error,) = _refused(kind, _file(kind), form)
    assert error.loc == ("options",) and error.type == "dict_type", error


def test_perfmap_reads_a_form_units_object_beside_a_request_file_as_beside_a_table():
    body = _file("perfmap")  # its flow in lbm/s
    assert _upload("perfmap", body, {"units": {"flow": "lb/s"}}).units.flow == "lbm/s"
    (error,) = _refused("perfmap", body, {"units": {"flow": "kg/s"}})
    assert error.loc == ("options", "units", "flow") and "'lbm/s'" in error.msg and "'kg/s'" in error.msg, error


@pytest.mark.parametrize("body", [_file("dedup"), None])
def test_a_dedup_form_units_is_refused_saying_the_model_states_its_own(body):
    (error,) = _refused("dedup", body, {"units": "mm"})
    assert error.loc == ("options", "units") and "IfcUnitAssignment" in error.msg, error
