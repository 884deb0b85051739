"""Passive monitoring (wait where you are until the plume arrives) and the strongest reading."""

from __future__ import annotations

import math

import numpy as np

from odorloc.core.types import Observation

__all__ = ["MaxTracker", "PassiveMonitor"]


class PassiveMonitor:
    """Remembers when the plume first reached the agent (its first detection)."""

    def __init__(self) -> None:
        self.arrival = math.nan

    def update(self, o: Observation) -> bool:
        """Feed one observation; ``True`` exactly when it is the first detection."""
        if o.detection and math.isnan(self.arrival):
            self.arrival = o.t
            return True
        return False


class MaxTracker:
    """Remembers the position of the strongest gas reading."""

    def __init__(self) -> None:
        self.best = -math.inf
        self.pos: np.ndarray | None = None

    def update(self, o: Observation) -> None:
        """Feed one observation."""
        if o.gas > self.best:
            self.best, self.pos = o.gas, o.position.copy()
