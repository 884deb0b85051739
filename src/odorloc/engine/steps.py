"""An episode's clock: the control period, the world's substeps and the number of steps."""

from __future__ import annotations

import math

from odorloc.core.errors import ConfigError
from odorloc.scenarios.config import Scenario

__all__ = ["control_substeps", "step_count"]


def control_substeps(scenario: Scenario) -> tuple[float, int, float]:
    """``(control period T, world substeps per period, world step)`` of a scenario, seconds."""
    T = scenario.limits.control_dt
    n_sub = max(1, round(T / scenario.world.dt))
    return T, n_sub, T / n_sub


def step_count(scenario: Scenario) -> int:
    """The control periods an episode may last: ``floor(limits.time / T)``.

    Raises
    ------
    ConfigError
        When ``limits.time`` is shorter than one control period.
    """
    T = scenario.limits.control_dt
    time = scenario.limits.time
    if time < T - 1e-9:
        raise ConfigError("limits.time", f"{time:g} s is shorter than one control period ({T:g} s)")
    # the tolerance keeps 10 s / 0.1 s at 100 periods, not 99
    return math.floor(time / T + 1e-9)
