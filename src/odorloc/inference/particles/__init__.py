"""Particle filters as compositions: filter, constraints, resampling, initialisation, stopping."""

from __future__ import annotations

from odorloc.inference.particles.constraints import ArenaConstraint, Constraint, place_admissible
from odorloc.inference.particles.convergence import (
    ConvergenceParams,
    ConvergenceStatus,
    DualConvergence,
)
from odorloc.inference.particles.filter import ParticleFilter, StoppingRule
from odorloc.inference.particles.init import backtrack_initialise, sample_free_uniform
from odorloc.inference.particles.resampling import (
    Resampler,
    RouletteParams,
    RouletteResampler,
    SystematicParams,
    SystematicResampler,
    multinomial,
    residual,
    stratified,
    systematic,
)

__all__ = [
    "ArenaConstraint",
    "Constraint",
    "ConvergenceParams",
    "ConvergenceStatus",
    "DualConvergence",
    "ParticleFilter",
    "Resampler",
    "RouletteParams",
    "RouletteResampler",
    "StoppingRule",
    "SystematicParams",
    "SystematicResampler",
    "backtrack_initialise",
    "multinomial",
    "place_admissible",
    "residual",
    "sample_free_uniform",
    "stratified",
    "systematic",
]
