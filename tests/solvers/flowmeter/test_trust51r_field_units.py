"""Field units a field file states in SI base spellings or in milligauss (trust51r probe): 'Bx [Wb/m^2]', 'V*s/m^2' (the
tesla, as older FE tools and field mappers label it) and 'mG' were refused as unknown units; each is read at its
factor to tesla. 'MG' stays unread (megagauss), as 'MT' does."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from plantsolve.solvers.flowmeter.field_file import FieldFileError, read_field_file

COMSOL = (Path(__file__).parents[3] / "examples" / "flowmeter" / "magnet_comsol.txt").read_text()
ROWS = np.array([[float(v) for v in line.split()] for line in COMSOL.splitlines()
                 if line.strip() and not line.startswith("%")])


def _csv(unit: str, factor: float) -> str:
    rows = ROWS.copy()
    rows[:, 3:] /= factor
    header = f"x [mm],y [mm],z [mm],Bx [{unit}],By [{unit}],Bz [{unit}]"
    return "\n".join([header, *(",".join(f"{v:.12g}" for v in row) for row in rows)]) + "\n"


@pytest.mark.parametrize("unit, factor", [("Wb/m^2", 1.0), ("Wb/m2", 1.0), ("WB/M2", 1.0), ("V*s/m^2", 1.0),
                                          ("mG", 1e-7), ("milligauss", 1e-7), ("kilogauss", 0.1)])
def test_a_field_unit_in_another_spelling_is_read_at_its_factor_to_tesla(unit, factor):
    read = read_field_file(_csv(unit, factor), "mm")
    expected = read_field_file(COMSOL, "mm")
    assert read.rows.shape == expected.rows.shape == (225, 6)
    np.testing.assert_allclose(read.rows, expected.rows, rtol=1e-11, atol=1e-15)


@pytest.mark.parametrize("unit", ["MG", "MT", "A/m"])
def test_a_field_unit_that_reads_otherwise_is_still_refused(unit):
    with pytest.raises(FieldFileError, match=f"field unit '{unit}' is not known"):
        read_field_file(_csv(unit, 1.0), "mm")
