"""Wind models: uniform, meandering, Farrell coarse-grid fields and indoor potential flow."""

from __future__ import annotations

from odorloc.wind.base import WindModel
from odorloc.wind.farrell import FarrellWind, FarrellWindParams
from odorloc.wind.meander import MeanderWind, MeanderWindParams, SecondOrderNoise, swing
from odorloc.wind.potential import Opening, PotentialWind, PotentialWindParams
from odorloc.wind.uniform import UniformWind, UniformWindParams

__all__ = [
    "FarrellWind",
    "FarrellWindParams",
    "MeanderWind",
    "MeanderWindParams",
    "Opening",
    "PotentialWind",
    "PotentialWindParams",
    "SecondOrderNoise",
    "UniformWind",
    "UniformWindParams",
    "WindModel",
    "swing",
]
