"""The kind map and the solver contract: explicit, checked, and loud when something is wrong."""

from __future__ import annotations

import sys
import types

import pytest
from pydantic import BaseModel

from plantsolve.schemas.common import Report
from plantsolve.solvers import alignment, dedup, flowmeter, perfmap, polyhedra, rigidity, tube
from plantsolve.solvers.base import ResultOperation, SolverSpec
from plantsolve.solvers.kinds import KINDS, load_kinds
from plantsolve.solvers.perfmap.query import answer_beta_query, answer_query


class _Req(BaseModel):
    x: float = 0.0


class _Res(BaseModel):
    report: Report = Report()


def _solve(request, progress):
    return _Res()


def _spec(kind="extra", **extra) -> SolverSpec:
    return SolverSpec(kind, _Req, _Res, _solve, "1", **extra)


def test_the_map_lists_each_package_spec_under_its_own_kind():
    assert dict(KINDS) == {"alignment": alignment.SPEC, "tube": tube.SPEC, "perfmap": perfmap.SPEC,
                           "polyhedra": polyhedra.SPEC, "flowmeter": flowmeter.SPEC,
                           "rigidity": rigidity.SPEC, "dedup": dedup.SPEC}
    for kind, spec in KINDS.items():
        assert spec.kind == kind and spec.version and spec.description
        assert spec.check_input and spec.parse_upload and spec.render_artifacts and spec.upload_extensions
        assert 0 < spec.soft_time_limit <= spec.time_limit
    with pytest.raises(TypeError):
        KINDS["new"] = alignment.SPEC  # read-only: kinds are added in the source, not at run time


def test_perfmap_declares_its_query_as_an_operation():
    operation, beta = perfmap.SPEC.operations
    assert operation.name == "query" and operation.answer is answer_query
    assert beta.name == "beta" and beta.answer is answer_beta_query
    assert alignment.SPEC.operations == tube.SPEC.operations == polyhedra.SPEC.operations == flowmeter.SPEC.operations == ()
    assert rigidity.SPEC.operations == dedup.SPEC.operations == ()


def _plugin(name: str, **attributes) -> str:
    module = types.ModuleType(name)
    module.__dict__.update(attributes)
    sys.modules[name] = module
    return name


def test_plugins_add_kinds_without_touching_the_map():
    name = _plugin("plantsolve_test_plugin_ok", SPECS=(_spec("extra"),))
    kinds = load_kinds([name])
    assert set(kinds) == set(KINDS) | {"extra"} and set(KINDS) == {"alignment", "tube", "perfmap", "polyhedra", "flowmeter",
                                                                   "rigidity", "dedup"}
    assert load_kinds([]) == KINDS


def test_a_broken_plugin_is_an_error_not_a_silent_skip():
    with pytest.raises(ModuleNotFoundError):
        load_kinds(["plantsolve_no_such_plugin_module"])
    with pytest.raises(ImportError, match="SPECS"):
        load_kinds([_plugin("plantsolve_test_plugin_nospecs")])
    with pytest.raises(ValueError, match="already registered"):
        load_kinds([_plugin("plantsolve_test_plugin_dup", SPECS=(_spec("tube"),))])
    with pytest.raises(TypeError, match="not a SolverSpec"):
        load_kinds([_plugin("plantsolve_test_plugin_bad", SPECS=("tube",))])


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"kind": "Ifc Dedup"}, "lower-case name"),
        ({"kind": ""}, "lower-case name"),
        ({"soft_time_limit": 10, "time_limit": 5}, "soft_time_limit"),
        ({"parse_upload": lambda f, c, o: _Req()}, "upload_extensions"),
        ({"parse_upload": lambda f, c, o: _Req(), "upload_extensions": ("csv",)}, "start with a dot"),
        ({"operations": (ResultOperation("q", _Req, _Res, lambda r, q: q),) * 2}, "repeat"),
    ],
)
def test_a_spec_states_its_contract_or_refuses_to_exist(kwargs, message):
    kind = kwargs.pop("kind", "extra")
    with pytest.raises(ValueError, match=message):
        _spec(kind, **kwargs)


def test_kind_names_with_underscores_keep_their_names():
    # the old registry built class names as kind.capitalize() + "Request": ifc_dedup -> Ifc_dedupRequest
    spec = _spec("ifc_dedup")
    assert spec.kind == "ifc_dedup" and spec.request_model is _Req
