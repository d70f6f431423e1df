"""``make test``'s scheduling: under ``-n 2 --dist loadgroup`` the integration tests run together on one
pytest-xdist worker, the others on any (see tests/support/xdist_groups.py)."""

from __future__ import annotations

import re
import subprocess
import sys
import textwrap

import tests.conftest
from tests.conftest import REPO
from tests.support import xdist_groups

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
    run = subprocess.run([sys.executable, "-m", "pytest", "-n", "2", "--dist", "loadgroup", "-v", "-p", "no:cacheprovider"],
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
