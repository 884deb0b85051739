"""Fixed-step infotaxis over the lattice directions (the baselines Col-Inf and Col-PF).

Infotaxis (Vergassola et al. 2007) on a particle belief: from the UAV's position, each of the
``3^d - 1`` lattice directions leads one cell away (:class:`~odorloc.planning.steps.StepPlanner`);
the planner goes where the expected entropy of the particle weights after the next measurement
is least (:func:`~odorloc.planning.rewards.expected_entropy`). The measurement's outcomes are the
model's count classes (:meth:`~odorloc.models.base.MeasurementModel.outcome_probabilities`) plus
a *found* outcome, as in infotaxis: the UAV lands within ``found_radius`` of the source. Given
*found*, the posterior keeps only the particles within that radius of the target, so its weight
entropy is small but not zero; the count classes are conditioned on *not found*.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from pydantic import Field

from odorloc.core.params import Positive
from odorloc.core.registry import register
from odorloc.inference.belief import ParticleBelief
from odorloc.inference.weights import normalise_log_weights
from odorloc.planning import kernels
from odorloc.planning.adaptive import merge_tail_classes
from odorloc.planning.base import Plan, Pose
from odorloc.planning.rewards import expected_entropy
from odorloc.planning.selection import select
from odorloc.planning.steps import LatticeParams, StepPlanner

__all__ = ["FixedStepInfotaxis", "FixedStepParams", "with_found_outcome"]


def with_found_outcome(
    outcome_probs: np.ndarray, targets: np.ndarray, hypotheses: np.ndarray, radius: float
) -> np.ndarray:
    """Outcome probabilities with a last *found* class, ``(M, Z + 1, N)``.

    ``found`` has probability 1 for the hypotheses within ``radius`` of the target (and the
    count classes 0), and 0 otherwise.
    """
    q = np.asarray(outcome_probs, float)
    d2 = ((targets[:, None, :] - hypotheses[None, :, :]) ** 2).sum(axis=2)  # (M, N)
    found = (d2 <= radius * radius).astype(float)
    out = np.concatenate([q * (1.0 - found)[:, None, :], found[:, None, :]], axis=1)
    return out


class FixedStepParams(LatticeParams):
    """Parameters of :class:`FixedStepInfotaxis`.

    Parameters
    ----------
    found_radius : float, metres
        A hypothesis within this distance of the target counts as found (the scenario's reach
        radius is the natural value).
    tail_mass : float
        Count classes beyond where the predicted count distribution's tail falls below this
        are merged (:func:`~odorloc.planning.adaptive.merge_tail_classes`).
    ties : {"random", "first"}
        Directions whose expected entropies agree to ``1e-9`` (relative) tie; far from any
        plume many do. ``random`` draws one, ``first`` takes the lowest index.
    """

    found_radius: Positive = 2.0
    tail_mass: float = Field(1e-6, gt=0.0, lt=0.1)
    ties: Literal["random", "first"] = "random"


@register("step_planner", "fixed-step-infotaxis", FixedStepParams, "one-cell infotaxis")
class FixedStepInfotaxis(StepPlanner):
    """Move one cell in the direction of least expected entropy (see the module docstring)."""

    params: FixedStepParams
    Params = FixedStepParams

    def plan(self, belief: ParticleBelief, pose: Pose, rng: np.random.Generator) -> Plan:
        pos = np.asarray(pose.position, float)
        targets = pos + self.steps
        ok = self.feasible(pos, targets)
        scores = np.full(len(targets), np.inf)
        work = 0
        if ok.any():
            model = self.bound_model(pose)
            x = belief.positions
            p = self.params
            q = model.outcome_probabilities(targets[ok], x)
            if self.compiled:
                # merge_tail_classes, with_found_outcome and expected_entropy in one kernel
                q = np.ascontiguousarray(q, dtype=float)
                keep = kernels.tail_cut(q @ belief.weights, p.tail_mass)
                w = normalise_log_weights(belief.log_weights)[1]
                t = np.ascontiguousarray(targets[ok], dtype=float)
                xc = np.ascontiguousarray(x, dtype=float)
                r = float(p.found_radius)
                scores[ok], n_classes = kernels.found_entropy(q, w, keep, t, xc, r * r)
                size = q.shape[0] * n_classes * q.shape[2]
            else:
                q = merge_tail_classes(belief.weights, q, p.tail_mass)
                q = with_found_outcome(q, targets[ok], x, p.found_radius)
                scores[ok] = expected_entropy(belief.log_weights, q)
                size = q.size
            work = size * (x.shape[1] + 1)
        k = select(scores, mode="min", feasible=ok, ties=self.params.ties, rtol=1e-9, rng=rng)
        return Plan(
            k, targets, scores, ok, int(work), {"length": 1 if k is not None else 0, "l_max": 1}
        )
