"""Plume models: filament (puff), Gaussian, Vergassola rate, Eulerian grid and replay."""

from __future__ import annotations

from odorloc.plume.base import PlumeModel, check_sources
from odorloc.plume.eulerian import EulerianParams, EulerianPlume, grid_interpolate
from odorloc.plume.filament import FilamentParams, FilamentPlume, filament_concentration
from odorloc.plume.gaussian import GaussianParams, GaussianPlume, gaussian_plume
from odorloc.plume.replay import (
    Movie,
    ReplayParams,
    ReplayPlume,
    ReplayWind,
    node_interpolate,
    record_movie,
)
from odorloc.plume.vergassola import (
    VergassolaParams,
    VergassolaPlume,
    correlation_length,
    poisson_log_likelihood,
    vergassola_rate,
)

__all__ = [
    "EulerianParams",
    "EulerianPlume",
    "FilamentParams",
    "FilamentPlume",
    "GaussianParams",
    "GaussianPlume",
    "Movie",
    "PlumeModel",
    "ReplayParams",
    "ReplayPlume",
    "ReplayWind",
    "VergassolaParams",
    "VergassolaPlume",
    "check_sources",
    "correlation_length",
    "filament_concentration",
    "gaussian_plume",
    "grid_interpolate",
    "node_interpolate",
    "poisson_log_likelihood",
    "record_movie",
    "vergassola_rate",
]
