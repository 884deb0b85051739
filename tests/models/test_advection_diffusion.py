"""The closed-form steady plume of a point source in a uniform 2-D wind."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.special import k0

from odorloc.core.errors import ConfigError
from odorloc.models.advection_diffusion import point_source_2d, point_source_flux_2d

SOURCE = np.array([1.0, 2.0])
WIND = np.array([3.0, 1.0])
Q, DA, DC = 0.7, 0.8, 0.3


def _c(points: np.ndarray) -> np.ndarray:
    return point_source_2d(points, SOURCE, Q, WIND, DA, DC)


def test_it_is_the_textbook_solution_when_isotropic() -> None:
    """c = Q / (2 pi D) exp(U x / 2D) K0(U r / 2D) for a wind along +x."""
    pts = np.array([[2.0, 0.5], [-0.5, 0.1], [0.3, -0.4]])
    U, D = 2.0, 0.4
    r = np.hypot(pts[:, 0], pts[:, 1])
    want = Q / (2 * math.pi * D) * np.exp(U * pts[:, 0] / (2 * D)) * k0(U * r / (2 * D))
    np.testing.assert_allclose(point_source_2d(pts, (0, 0), Q, (U, 0.0), D), want, rtol=1e-12)


def test_it_solves_the_steady_advection_diffusion_equation() -> None:
    # U dc/dxi = D_a d2c/dxi2 + D_c d2c/deta2 away from the source (finite differences)
    e = WIND / np.linalg.norm(WIND)
    n = np.array([-e[1], e[0]])
    h = 1e-3
    for p in np.array([[2.0, 2.5], [0.5, 1.7], [1.3, 3.0]]):
        c0 = _c(p[None])[0]
        d1 = (_c([p + h * e]) - _c([p - h * e]))[0] / (2 * h)
        d2e = (_c([p + h * e]) - 2 * c0 + _c([p - h * e]))[0] / h**2
        d2n = (_c([p + h * n]) - 2 * c0 + _c([p - h * n]))[0] / h**2
        residual = np.linalg.norm(WIND) * d1 - DA * d2e - DC * d2n
        assert abs(residual) < 1e-4 * c0


@pytest.mark.parametrize("radius", [0.05, 0.5, 3.0])
def test_the_flux_leaving_any_circle_around_the_source_is_the_release(radius: float) -> None:
    th = np.linspace(0.0, 2 * math.pi, 4001)[:-1]
    normal = np.column_stack([np.cos(th), np.sin(th)])
    flux = point_source_flux_2d(SOURCE + radius * normal, SOURCE, Q, WIND, DA, DC)
    out = float((flux * normal).sum(axis=1).mean() * 2 * math.pi * radius)
    assert out == pytest.approx(Q, rel=1e-6)


def test_upwind_it_decays_over_d_along_over_u() -> None:
    # far upwind on the axis c ~ exp(-U |x| / D_a) / sqrt(|x|): doubling D_a doubles the length
    x = np.array([[-2.0, 0.0], [-3.0, 0.0]])
    for D in (0.5, 1.0):
        c = point_source_2d(x, (0, 0), 1.0, (5.0, 0.0), D, 0.5)
        rate = -math.log(c[1] / c[0] * math.sqrt(3.0 / 2.0))
        assert rate == pytest.approx(5.0 / D, rel=0.05)


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"wind": (0.0, 0.0)}, "wind"),
        ({"wind": (math.nan, 1.0)}, "wind"),
        ({"D_along": 0.0}, "D"),
        ({"D_across": -1.0}, "D"),
        ({"points": np.zeros((2, 3))}, "points"),
    ],
)
def test_bad_input_is_refused(kwargs: dict, field: str) -> None:
    args = {
        "points": np.ones((2, 2)),
        "source": (0, 0),
        "rate": 1.0,
        "wind": (1, 0),
        "D_along": 1.0,
    }
    args.update(kwargs)
    with pytest.raises(ConfigError) as err:
        point_source_2d(**args)
    assert err.value.field == field
