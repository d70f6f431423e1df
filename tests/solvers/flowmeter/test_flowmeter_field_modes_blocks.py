"""The field's z modes (grid_weight.field_modes) made in blocks: the same numbers, to the last bit, as the one
array expression over every column, knot and mode, whatever the block; a closed form; memory bounded by the
block, not by columns x knots x modes."""

import tracemalloc

import numpy as np
import pytest

from plantsolve.solvers.flowmeter.field import FieldGrid
from plantsolve.solvers.flowmeter.grid_weight import field_modes


def one_expression(grid: FieldGrid, cut: float, count: int) -> tuple[np.ndarray, np.ndarray]:
    """b_n at the columns as one (columns x knots x modes) array expression, written out here as the reference."""
    k = np.arange(count) * np.pi / cut
    knots = np.concatenate([[-cut], grid.z[(grid.z > -cut) & (grid.z < cut)], [cut]])
    z0, z1 = knots[:-1], knots[1:]
    out = []
    for values in (grid.bx, grid.by):
        columns = values.reshape(-1, len(grid.z))
        at = np.stack([np.interp(knots, grid.z, c) for c in columns])
        slope = (at[:, 1:] - at[:, :-1]) / (z1 - z0)
        offset = at[:, :-1] - slope * z0
        total = np.zeros((len(columns), count))
        total[:, 0] = np.sum(offset * (z1 - z0) + slope * (z1**2 - z0**2) / 2, axis=1)
        kk = k[1:][None, None, :]
        for zb, sign in ((z1, 1.0), (z0, -1.0)):
            zz = zb[None, :, None]
            value = (offset[:, :, None] + slope[:, :, None] * zz) * np.sin(kk * zz) / kk \
                + slope[:, :, None] * np.cos(kk * zz) / kk**2
            total[:, 1:] += sign * value.sum(axis=1)
        out.append(total.reshape(len(grid.x), len(grid.y), count))
    return out[0], out[1]


def random_grid(nx: int, ny: int, z: np.ndarray, seed: int) -> FieldGrid:
    rng = np.random.default_rng(seed)
    x, y = np.linspace(-1.2, 1.2, nx), np.linspace(-1.1, 1.1, ny)
    return FieldGrid(x, y, z, rng.normal(size=(nx, ny, len(z))), rng.normal(size=(nx, ny, len(z))), 1.0)


@pytest.mark.parametrize("z, cut", [(np.linspace(-4.0, 4.0, 41), 3.0),  # the grid reaches beyond the liner
                                    (np.linspace(-2.0, 2.0, 23), 3.0),  # held constant beyond its last plane
                                    (np.array([-3.0, -0.4, 0.1, 3.0]), 3.0)])  # planes on the cut, few knots
def test_every_block_gives_the_one_expression_bit_for_bit(z, cut):
    grid = random_grid(3, 4, z, seed=7)
    want = one_expression(grid, cut, 97)
    # 96 modes. Block 1 or 7: one column and one knot at a time; 96 * 5: five knots at a time; 96 * 40: every knot
    # of one column at a time (all 12 columns in the third case); 10**6: everything at once
    for block in (1, 7, 96 * 5, 96 * 40, 10**6):
        got = field_modes(grid, cut, 97, block=block)
        assert np.array_equal(got[0], want[0]) and np.array_equal(got[1], want[1]), block


def test_a_tent_along_z_gives_its_closed_form_in_blocks():
    # B = max(0, 1 - |z|/h): integral B cos(kz) dz = 2 (1 - cos(kh)) / (k^2 h), and h for k = 0
    h, cut, count = 0.5, 3.0, 97
    z = np.linspace(-3.0, 3.0, 25)  # step 0.25: -h, 0 and h are planes
    tent = np.maximum(0.0, 1 - np.abs(z) / h)
    grid = FieldGrid(np.array([-1.0, 1.0]), np.array([-1.0, 1.0]), z, np.zeros((2, 2, 25)),
                     np.broadcast_to(tent, (2, 2, 25)).copy(), 1.0)
    k = np.arange(1, count) * np.pi / cut
    bx, by = field_modes(grid, cut, count, block=5)
    assert np.all(bx == 0.0)
    assert by[1, 0, 0] == pytest.approx(h, rel=1e-14)
    assert by[1, 0, 1:] == pytest.approx(2 * (1 - np.cos(k * h)) / (k**2 * h), rel=1e-12, abs=1e-15)


def test_memory_is_bounded_by_the_block_not_by_the_grid():
    # 20 x 20 columns, 45 knots within the cut, 96 modes: one array of the terms alone is 6.6 MB
    grid = random_grid(20, 20, np.linspace(-3.3, 3.3, 50), seed=3)
    tracemalloc.start()
    try:
        field_modes(grid, 3.0, 97, block=20_000)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    outputs = 2 * 20 * 20 * 97 * 8
    assert peak < outputs + 2.5e6  # the outputs, the columns' offsets and slopes, two 160 kB buffers
