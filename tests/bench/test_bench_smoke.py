"""The API bench runs to its table (smoke mode: about a second per phase). A bench that cannot finish measures
nothing: a pipe that nobody read once stalled it for good."""

from __future__ import annotations

import re
import subprocess
import sys

import pytest

from tests.conftest import REPO


@pytest.mark.slow
def test_the_api_bench_finishes_and_prints_its_table_with_the_baseline(tmp_path):
    done = subprocess.run([sys.executable, str(REPO / "bench" / "api.py"), "--smoke", "--port", "18961"], cwd=REPO,
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-3000:]
    rows = {line.split()[0]: line.split() for line in done.stdout.splitlines() if re.match(r"(baseline|embedded) ", line)}
    assert set(rows) == {"baseline", "embedded"}, done.stdout
    assert int(rows["embedded"][1]) > 0  # jobs submitted
    cpu = re.findall(r"\s(\d+\.\d\d)\s+(\d+\.\d\d)x\s+(?:-|met|MISSED)$", done.stdout, re.M)
    assert len(cpu) == 2 and all(float(ms) > 0 for ms, _ in cpu), done.stdout
