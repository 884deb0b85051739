"""The compiled multilinear interpolation equals the NumPy one to the bit."""

from __future__ import annotations

import numpy as np
import pytest

from odorloc.core.jit import HAVE_NUMBA
from odorloc.geometry import grid


@pytest.mark.skipif(not HAVE_NUMBA, reason="the compiled path needs numba")
@pytest.mark.parametrize("dim", [1, 2, 3])
@pytest.mark.parametrize("uniform", [True, False])
def test_compiled_multilinear_equals_numpy(dim: int, uniform: bool, monkeypatch) -> None:  # type: ignore[no-untyped-def]
    rng = np.random.default_rng(dim + 10 * uniform)
    axes = []
    for a in range(dim):
        n = 1 if (dim == 3 and a == 1) else 5 + a
        ax = np.linspace(-1.0, 3.0, n) if uniform else np.sort(rng.uniform(-1, 3, n))
        axes.append(ax)
    values = rng.normal(size=(*(len(ax) for ax in axes), 3))
    points = rng.uniform(-2.0, 4.0, (200, dim))
    points[:5] = np.array([ax[min(2, len(ax) - 1)] for ax in axes])  # on nodes
    compiled = grid.multilinear(values, axes, points)
    # the same axes with other values (the axes' arrays are prepared once)
    other = grid.multilinear(values[..., ::-1], axes, points)
    monkeypatch.setattr(grid, "HAVE_NUMBA", False)
    reference = grid.multilinear(values, axes, points)
    np.testing.assert_array_equal(compiled, reference)
    np.testing.assert_array_equal(other, grid.multilinear(values[..., ::-1], axes, points))
    # a point on a node gets that node's value
    idx = tuple(min(2, len(ax) - 1) for ax in axes)
    np.testing.assert_array_equal(compiled[0], values[idx])
