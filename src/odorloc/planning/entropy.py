"""Expected-entropy move selection: candidates x reward x selection (indoor PF paper, 2.2).

The robot evaluates a small set of moves ``M_k`` (forward, backward, left, right in its own
frame: the candidates ``moves``, :func:`~odorloc.planning.candidates.move_directions`) and picks
``m_k* = argmin_{m in M_k} H(m_k)`` (eq. 18), ``H`` being the Shannon entropy of the source
posterior expected after the reading the robot would take at the end of the move. The flattened
eq. 17 mixes the likelihood into the entropy; it is read here, as in infotaxis / entrotaxis (the
works it cites), as the expected posterior entropy (the reward ``expected-entropy``,
:func:`~odorloc.planning.rewards.expected_entropy`). Moves blocked by walls or obstacles are
excluded; ties go to the first move in :data:`MOVE_NAMES` order.

:class:`EntropyPlanner` is the particle planner (:class:`~odorloc.planning.infotaxis.
ParticlePlanner`) with these parts as its defaults; it is model-agnostic: the caller's model,
bound to the conditions of the anticipated reading (:attr:`~odorloc.planning.base.Pose.
conditions`), gives the outcome probabilities ``(M, Z, N)``.
"""

from __future__ import annotations

from odorloc.core.registry import ComponentRef, Ref, register
from odorloc.planning.candidates import MOVE_NAMES
from odorloc.planning.infotaxis import ParticlePlanner, ParticlePlannerParams

__all__ = ["MOVE_NAMES", "EntropyPlanner", "EntropyPlannerParams"]


class EntropyPlannerParams(ParticlePlannerParams):
    """Parameters of :class:`EntropyPlanner`: the particle planner's parts, with the indoor PF
    paper's as defaults.

    Attributes
    ----------
    candidates : dict
        ``{type: moves, frame: robot | wind | world, step_length: ...}`` (paper: robot frame; a
        step of one control period at the platform's top speed).
    reward : dict
        ``{type: expected-entropy}`` (eq. 18).
    selection : dict
        ``{type: best, ties: first, tolerance: 0}``.
    """

    candidates: Ref("candidates") = ComponentRef(type="moves")
    reward: Ref("reward") = ComponentRef(type="expected-entropy")
    selection: Ref("selection") = ComponentRef(type="best")


@register("planner", "entropy", EntropyPlannerParams, "moves minimising the expected entropy")
class EntropyPlanner(ParticlePlanner):
    """Pick the move whose reading minimises the expected posterior entropy (eq. 18)."""

    params: EntropyPlannerParams
    Params = EntropyPlannerParams

    def __init__(self, params: EntropyPlannerParams | None = None) -> None:
        super().__init__(params or EntropyPlannerParams())
