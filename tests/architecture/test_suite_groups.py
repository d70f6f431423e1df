"""``make test``'s scheduling: under ``-n 2 --dist loadgroup`` the integration tests run together on one
pytest-xdist worker, the others on any (see tests/support/xdist_groups.py); and its measure, each test's CPU and
wall with PLANTSOLVE_TEST_CPU_LOG set (tests/support/cpu_log.py)."""

from __future__ import annotations

import re
import subprocess
import sys
import textwrap

import tests.conftest
from tests.conftest import REPO
from tests.support import xdist_groups

# the installed plugins these small suites do not use, left out of their three pytest processes each: schemathesis
# and hypothesis alone take about 0.9 CPU s of each process's start
UNUSED_PLUGINS = ("-p", "no:schemathesis", "-p", "no:hypothesispytest", "-p", "no:anyio", "-p", "no:platformdirs")
PLAIN = 4
INTEGRATION = 5  # the module's two, the one-test marks, the marked parameter


def test_the_integration_tests_run_on_one_worker_whatever_marks_them(tmp_path):
    """A small suite run with the collection hook of the repository's conftest: every integration test (module-wide,
    one-test and parameter marks alike) reaches the same worker, with its group in its id. Two xdist workers
    and their controller start in subprocesses (a few seconds): no cheaper run exercises the real scheduler."""
    (tmp_path / "pytest.ini").write_text("[pytest]\nmarkers =\n    integration: real services\n")
    (tmp_path / "conftest.py").write_text(f"from {xdist_groups.__name__} import pytest_collection_modifyitems  # noqa: F401\n")
    (tmp_path / "test_marked.py").write_text(textwrap.dedent("""\
        import pytest
        pytestmark = pytest.mark.integration
        def test_module_wide_a(): pass
        def test_module_wide_b(): pass
        """))
    (tmp_path / "test_mixed.py").write_text(textwrap.dedent(f"""\
        import pytest
        @pytest.mark.integration
        def test_one_marked(): pass
        @pytest.mark.parametrize("where", ["here", pytest.param("there@x", marks=pytest.mark.integration)])
        def test_parameter_marked(where): pass
        @pytest.mark.parametrize("n", range({PLAIN}))
        def test_plain(n): pass
        @pytest.mark.integration
        def test_last_marked(): pass
        """))
    run = subprocess.run([sys.executable, "-m", "pytest", "-n", "2", "--dist", "loadgroup", "-v", "-p", "no:cacheprovider",
                          *UNUSED_PLUGINS],
                         check=False, cwd=tmp_path, env={"PYTHONPATH": str(REPO), "PATH": "/usr/bin:/bin"},
                         capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stdout + run.stderr
    ran = re.findall(r"^\[(gw\d)\] \[ *\d+%\] PASSED (\S+)", run.stdout, flags=re.MULTILINE)
    assert len(ran) == PLAIN + 1 + INTEGRATION, run.stdout
    integration = {nodeid: worker for worker, nodeid in ran if nodeid.endswith("@integration")}
    assert len(integration) == INTEGRATION, run.stdout
    assert len(set(integration.values())) == 1, integration
    assert "test_parameter_marked[here]" in " ".join(nodeid for _, nodeid in ran)  # its plain parameter ungrouped


def test_the_suites_conftest_holds_the_grouping_hook():
    assert tests.conftest.pytest_collection_modifyitems is xdist_groups.pytest_collection_modifyitems


def test_the_cpu_log_charges_each_test_its_own_and_its_childrens_cpu_not_its_waits(tmp_path):
    """PLANTSOLVE_TEST_CPU_LOG=<file> (tests/support/cpu_log.py, hooked in by the repository's conftest): one line
    per test, under two xdist workers as in ``make test``. A test that waits 0.4 s costs wall, not CPU; one that
    spins 0.4 s of its own CPU and one whose subprocess spins 0.4 s are charged at least that, each in its column;
    the children's CPU comes from the kernel's count, not the child's word."""
    (tmp_path / "conftest.py").write_text("from tests.support.cpu_log import pytest_runtest_protocol  # noqa: F401\n")
    (tmp_path / "test_costs.py").write_text(textwrap.dedent("""\
        import subprocess, sys, time
        SPIN = "import time\\nstart = time.process_time()\\nwhile time.process_time() - start < 0.4: pass\\n"
        def test_waits(): time.sleep(0.4)
        def test_spins(): exec(SPIN)
        def test_spins_in_a_child(): subprocess.run([sys.executable, "-c", SPIN], check=True)
        """))
    log = tmp_path / "cpu.jsonl"
    run = subprocess.run([sys.executable, "-m", "pytest", "-n", "2", "-p", "no:cacheprovider", "-q", *UNUSED_PLUGINS], check=False,
                         cwd=tmp_path, capture_output=True, text=True, timeout=300,
                         env={"PYTHONPATH": str(REPO), "PATH": "/usr/bin:/bin", "PLANTSOLVE_TEST_CPU_LOG": str(log)})
    assert run.returncode == 0, run.stdout + run.stderr
    from tests.support import cpu_log

    rows = {row["nodeid"].split("::")[1]: row for row in cpu_log.read(str(log))}
    assert set(rows) == {"test_waits", "test_spins", "test_spins_in_a_child"}
    assert {row["worker"] for row in rows.values()} <= {"gw0", "gw1"}
    waits, spins, child = rows["test_waits"], rows["test_spins"], rows["test_spins_in_a_child"]
    assert waits["wall"] >= 0.4 and waits["cpu"] < 0.2
    assert spins["own_cpu"] >= 0.4 and spins["children_cpu"] == 0.0
    assert child["children_cpu"] >= 0.4 and child["own_cpu"] < 0.3
    for row in rows.values():
        assert abs(row["cpu"] - row["own_cpu"] - row["children_cpu"]) <= 2e-4  # each rounded to 0.1 ms
    ranked = cpu_log.rank(list(rows.values()), top=3)
    assert ranked.startswith("3 tests,") and ranked.index("test_spins_in_a_child") < ranked.index("top 3 by wall")


def test_the_suites_conftest_holds_the_cpu_log_hook():
    from tests.support import cpu_log

    assert tests.conftest.pytest_runtest_protocol is cpu_log.pytest_runtest_protocol
