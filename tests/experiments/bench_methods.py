"""User methods for the benchmark's tests, given by import path (``bench_methods:Class``)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from pydantic import Field

from odorloc.core.types import Action, Command, Observation
from odorloc.searchers.infotaxis import InfotaxisParams, InfotaxisSearcher


class BlunderParams(InfotaxisParams):
    """Infotaxis that takes a random axis move instead of its plan with probability
    ``blunder``."""

    blunder: float = Field(default=0.6, ge=0.0, le=1.0)


class BlunderInfotaxis(InfotaxisSearcher):
    """A deliberately weakened infotaxis (its random moves come from the searcher's stream)."""

    Params = BlunderParams
    params: BlunderParams

    def __init__(self, params: BlunderParams | None = None) -> None:
        super().__init__(params or BlunderParams())

    def act(self, observations: Sequence[Observation], rng: np.random.Generator) -> Action:
        """The plan, or with probability ``blunder`` a random unit move along an axis."""
        action = super().act(observations, rng)
        if observations[0].ready and rng.random() < self.params.blunder:
            step = np.zeros(len(observations[0].position))
            step[rng.integers(step.size)] = rng.choice((-1.0, 1.0))
            return Action([Command.move(step)])
        return action
