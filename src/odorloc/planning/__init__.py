"""Planners: where to go next given a belief (entropy moves, grid paths, coverage patterns)."""

from odorloc.planning.astar import astar_path, path_length, smooth_path
from odorloc.planning.entropy import (
    EntropyPlan,
    EntropyPlanner,
    EntropyPlannerParams,
    expected_posterior_entropy,
    move_directions,
    pointwise,
)
from odorloc.planning.uncertainty_route import (
    RoutePlan,
    UncertaintyRouteParams,
    UncertaintyRoutePlanner,
)

__all__ = [
    "EntropyPlan",
    "EntropyPlanner",
    "EntropyPlannerParams",
    "RoutePlan",
    "UncertaintyRouteParams",
    "UncertaintyRoutePlanner",
    "astar_path",
    "expected_posterior_entropy",
    "move_directions",
    "path_length",
    "pointwise",
    "smooth_path",
]
