"""The kind map and the solver contract: explicit, checked, and loud when something is wrong."""

from __future__ import annotations

import importlib
import os
import subprocess
import sys
import types

import pytest
from pydantic import BaseModel

from plantsolve.schemas.common import Report
from plantsolve.solvers import alignment, dedup, flowmeter, perfmap, polyhedra, rigidity, tube
from plantsolve.solvers.base import Deferred, ResultOperation, SolverSpec
from plantsolve.solvers.kinds import KINDS, PACKAGES, KindMap, load_kinds
from plantsolve.workers.processes import warm_modules
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
    assert PACKAGES == {kind: f"plantsolve.solvers.{kind}" for kind in KINDS}


def test_a_kind_named_by_another_kinds_package_is_refused_when_asked_for():
    wrong = KindMap({"tube": "plantsolve.solvers.rigidity"})
    assert list(wrong) == ["tube"]
    with pytest.raises(ValueError, match="'tube' names plantsolve.solvers.rigidity"):
        wrong["tube"]
    with pytest.raises(KeyError):
        KINDS["no_such_kind"]
    assert "tube" in KINDS and "no_such_kind" not in KINDS and KINDS.get("no_such_kind") is None


def _imported_after(code: str) -> set[str]:
    """The modules a fresh interpreter holds after ``code``."""
    code += "\nprint(' '.join(sorted(sys.modules)))"
    return set(subprocess.run([sys.executable, "-c", "import sys\n" + code], capture_output=True, text=True,
                              check=True).stdout.split())


def test_the_map_imports_a_kind_when_it_is_asked_for_and_that_kind_alone():
    """Listing the kinds imports none of their packages; a run of one kind (``plantsolve solve tube``: the parser
    without the kinds' descriptions, then the spec) imports that kind's package and schema, no other kind's."""
    listed = _imported_after("from plantsolve.solvers.kinds import KINDS\nsorted(KINDS)")
    assert not {m for m in listed if m.startswith(("plantsolve.solvers.", "plantsolve.schemas.")) and
                m.removeprefix("plantsolve.solvers.").removeprefix("plantsolve.schemas.") in KINDS}
    one = _imported_after("from plantsolve.solvers.kinds import KINDS\nfrom plantsolve.cli import build_parser\n"
                          "build_parser(KINDS, describe_kinds=False).parse_args(['solve', 'tube', 'x.json'])\n"
                          "KINDS['tube'].request_model")
    for kind in KINDS:
        held = {f"plantsolve.solvers.{kind}", f"plantsolve.schemas.{kind}"} & one
        assert held == ({f"plantsolve.solvers.{kind}", f"plantsolve.schemas.{kind}"} if kind == "tube" else set()), held


def test_the_warm_parent_of_the_job_processes_imports_every_function_of_every_kind():
    """The job processes start warm because their parent asks the map for every kind, explicitly."""
    modules = warm_modules(KINDS.values(), ["plantsolve_test_plugin"])
    for kind, spec in KINDS.items():
        assert set(spec.modules()) <= set(modules) and any(m.startswith(f"plantsolve.solvers.{kind}.") for m in modules)
    assert modules[:3] == ["plantsolve.workers.processes", "plantsolve.jobs.intake", "plantsolve_test_plugin"]


def test_perfmap_declares_its_query_as_an_operation():
    operation, beta = perfmap.SPEC.operations
    assert operation.name == "query" and operation.answer.target is answer_query
    assert beta.name == "beta" and beta.answer.target is answer_beta_query
    assert alignment.SPEC.operations == tube.SPEC.operations == polyhedra.SPEC.operations == flowmeter.SPEC.operations == ()
    assert rigidity.SPEC.operations == dedup.SPEC.operations == ()


@pytest.mark.parametrize("kind", sorted(KINDS))
def test_each_function_of_a_spec_is_its_own_package_function_named_by_reference(kind):
    """A spec names its functions ("module:attribute"), so the map imports no solver; each reference resolves to
    a function of the kind's own package (the import rules hold for the imports these references make)."""
    spec = KINDS[kind]
    for role in SolverSpec.FUNCTIONS:
        function = getattr(spec, role)
        if function is None or role == "example":  # the example is JSON in the package (test_kinds_examples.py)
            continue
        assert isinstance(function, Deferred), f"{kind}.{role} is imported with the map"
        assert function.module.startswith(f"plantsolve.solvers.{kind}."), function
        assert callable(function.target)
    for operation in spec.operations:
        assert isinstance(operation.answer, Deferred) and callable(operation.answer.target)
    assert spec.modules(SolverSpec.READERS) and set(spec.modules(SolverSpec.READERS)) <= set(spec.modules())


@pytest.mark.parametrize("kind", sorted(KINDS))
def test_the_upload_extensions_of_a_spec_are_those_its_reader_reads(kind):
    upload = importlib.import_module(f"plantsolve.solvers.{kind}.upload")
    assert KINDS[kind].upload_extensions == upload.UPLOAD_EXTENSIONS


HEAVY = ("scipy", "matplotlib", "ifcopenshell", "networkx", "skfem", "trimesh", "pyamg", "fcl", "openpyxl", "laspy",
         "sqlalchemy", "fastapi")


def test_listing_the_kinds_imports_no_solver():
    """The kind map, its schemas and ``plantsolve solve --help``'s parser, in a fresh interpreter: none of the
    solvers' libraries is imported (they cost seconds and hundreds of MiB per process)."""
    code = ("import sys\nfrom plantsolve.solvers.kinds import KINDS\nfrom plantsolve.cli import build_parser\n"
            "build_parser(KINDS).format_help()\n"
            "print(' '.join(sorted({m.split('.')[0] for m in sys.modules})))")
    loaded = set(subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split())
    assert not loaded & set(HEAVY), sorted(loaded & set(HEAVY))
    assert not {m for m in loaded if m.startswith("plantsolve.solvers.") and m.count(".") > 2}


def test_the_api_process_imports_no_solver(tmp_path):
    """The app with its routes and OpenAPI document (every kind's schemas and example) imports no solver module:
    uploads are read in the readers' processes, jobs run in job processes."""
    code = ("import sys\nfrom plantsolve.app.main import create_app\nfrom plantsolve.app.settings import get_settings\n"
            "create_app(get_settings()).openapi()\n"
            "print(' '.join(sorted({m.split('.')[0] for m in sys.modules})))\n"
            "print(' '.join(m for m in sys.modules if m.startswith('plantsolve.solvers.') and m.count('.') > 2))")
    env = {name: value for name, value in os.environ.items() if name not in ("DATABASE_URL", "ARTIFACT_DIR", "BROKER_URL")}
    env["DATA_DIR"] = str(tmp_path)
    libraries, solvers = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                                        env=env, cwd=tmp_path).stdout.split("\n")[:2]
    assert not set(libraries.split()) & set(HEAVY) - {"sqlalchemy", "fastapi"}, libraries
    assert not solvers.split(), solvers


def test_a_deferred_function_is_imported_on_first_use_and_travels_by_name():
    import pickle

    function = Deferred("plantsolve.solvers.perfmap.query:answer_query")
    assert function == Deferred("plantsolve.solvers.perfmap.query:answer_query") and "answer_query" in repr(function)
    assert function.target is answer_query and function.target is function.target
    copy = pickle.loads(pickle.dumps(function))
    assert copy == function and copy.target is answer_query
    assert Deferred("plantsolve.solvers.tube.scan:TubeScan.load").target.__qualname__ == "TubeScan.load"
    copy = pickle.loads(pickle.dumps(tube.SPEC))
    assert copy.solve == tube.SPEC.solve and copy.example() == tube.SPEC.example()
    with pytest.raises(ValueError, match="reference"):
        Deferred("plantsolve.solvers.perfmap.query.answer_query")
    with pytest.raises(ModuleNotFoundError):
        Deferred("plantsolve.solvers.perfmap.no_such_module:f").target
    with pytest.raises(TypeError, match="not callable"):
        Deferred("plantsolve.solvers.perfmap:__version__").target


def test_a_spec_made_of_references_validates_them_when_made():
    spec = _spec(check_input="plantsolve.solvers.perfmap.validation:check_input")
    assert isinstance(spec.check_input, Deferred) and spec.modules() == ["plantsolve.solvers.perfmap.validation"]
    with pytest.raises(ValueError, match="reference"):
        _spec(check_input="not a reference")


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
