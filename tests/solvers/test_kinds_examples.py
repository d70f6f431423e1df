"""Each kind's example request is stored as ``example.json`` in its package (the API documents every kind without
importing a generator) and is exactly what its ``synthetic.example()`` makes.

After changing a kind's ``synthetic.example()``: ``python tests/solvers/test_kinds_examples.py --write``.
"""

from __future__ import annotations

import importlib
import json
import sys
from pathlib import Path

import pytest

from plantsolve.solvers.kinds import KINDS

PACKAGE = Path(__file__).resolve().parents[2] / "plantsolve" / "solvers"


def generated(kind: str) -> dict:
    return importlib.import_module(f"plantsolve.solvers.{kind}.synthetic").example()


@pytest.mark.parametrize("kind", sorted(KINDS))
def test_the_stored_example_is_what_the_generator_makes(kind):
    stored = KINDS[kind].example()
    assert stored == json.loads(json.dumps(generated(kind))), (
        f"plantsolve/solvers/{kind}/example.json is stale: python tests/solvers/test_kinds_examples.py --write")
    stored["mutated"] = True  # every call reads a fresh copy: a caller's change stays its own
    assert "mutated" not in KINDS[kind].example()


def write() -> None:
    for kind in sorted(KINDS):
        (PACKAGE / kind / "example.json").write_text(json.dumps(generated(kind), indent=1) + "\n")


if __name__ == "__main__" and sys.argv[1:] == ["--write"]:
    write()
