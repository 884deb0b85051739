"""Plume models: filament (puff), Gaussian, Vergassola rate, Eulerian grid, replay and the
isotropic lattice hits of infotaxis (``lattice-isotropic``)."""

from __future__ import annotations

from odorloc.plume.base import PlumeModel, check_sources
from odorloc.plume.eulerian import EulerianParams, EulerianPlume, grid_interpolate
from odorloc.plume.filament import FilamentParams, FilamentPlume, filament_concentration
from odorloc.plume.gaussian import GaussianPlume
from odorloc.plume.replay import (
    Movie,
    ReplayParams,
    ReplayPlume,
    ReplayWind,
    record_movie,
)
from odorloc.plume.sources import Modulation, Source
from odorloc.plume.vergassola import VergassolaParams, VergassolaPlume

__all__ = [
    "EulerianParams",
    "EulerianPlume",
    "FilamentParams",
    "FilamentPlume",
    "GaussianPlume",
    "Modulation",
    "Movie",
    "PlumeModel",
    "ReplayParams",
    "ReplayPlume",
    "ReplayWind",
    "Source",
    "VergassolaParams",
    "VergassolaPlume",
    "check_sources",
    "filament_concentration",
    "grid_interpolate",
    "record_movie",
]
