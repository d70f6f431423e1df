"""Every kind's result states the unit of every number, and every plausibility code is documented.

A number without its unit is how a 1.93 mV signal comes back as "1.93": the OpenAPI document states each
result field's unit (``x-unit``), and the README's kind sections state the range behind each
``implausible_<quantity>`` warning the solvers can raise.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from plantsolve.solvers.kinds import KINDS
from tests.support.units import numbers_without_unit, unreadable_units

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("kind", sorted(KINDS))
def test_every_number_of_a_result_has_a_unit(kind):
    assert numbers_without_unit(KINDS[kind].result_model) == []


@pytest.mark.parametrize("kind", sorted(KINDS))
def test_every_stated_unit_is_readable(kind):
    assert unreadable_units(KINDS[kind].result_model) == []


def test_the_check_finds_a_number_without_unit():
    from pydantic import BaseModel, Field

    from plantsolve.schemas.common import unit

    class Inner(BaseModel):
        bare: float
        given: float = Field(json_schema_extra=unit("V"))

    class Outer(BaseModel):
        inner: list[Inner]
        count: int
        volume: float | None = Field(default=None, json_schema_extra=unit("{units}^3"))
        odd: float = Field(json_schema_extra=unit("furlongs per parsec per zz"))

    assert numbers_without_unit(Outer) == ["Outer.inner.bare"]
    assert len(unreadable_units(Outer)) == 1


def test_every_plausibility_code_is_documented():
    codes = set()
    for path in (ROOT / "plantsolve").rglob("*.py"):
        codes |= set(re.findall(r"[\"'](implausible_[a-z0-9_]*[a-z0-9])[\"']", path.read_text(encoding="utf-8")))
    assert codes, "no implausible_* warning in the solvers"
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    assert sorted(c for c in codes if c not in readme) == []
