"""Lattice step planners of the multi-UAV paper: Adap-PP (eqs. 21-28) and fixed-step infotaxis."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from odorloc.core.errors import ConfigError
from odorloc.core.types import SearchContext
from odorloc.geometry.arena import Arena
from odorloc.geometry.vectors import directions_26
from odorloc.inference.belief import ParticleBelief
from odorloc.models.poisson import censored_poisson
from odorloc.models.vergassola import VergassolaModel
from odorloc.planning.adaptive import (
    AdaptivePathPlanner,
    AdaptivePlannerParams,
    direction_rewards,
    max_step,
    merge_tail_classes,
    source_area_ratio,
    step_rewards,
)
from odorloc.planning.base import Plan, Pose
from odorloc.planning.fixed_step import FixedStepInfotaxis, FixedStepParams, with_found_outcome
from odorloc.planning.rewards import expected_entropy
from odorloc.planning.steps import lattice_offsets


def _plan(planner, belief, pos, history, rng, **conditions) -> Plan:
    """One decision from ``pos`` after the measurement points ``history``."""
    for p in history:
        planner.record(p)
    return planner.plan(belief, Pose(np.asarray(pos, float), conditions=conditions), rng)


def _ctx(upper: tuple[float, ...] = (100.0, 60.0, 30.0)) -> SearchContext:
    d = len(upper)
    return SearchContext(
        arena=Arena.box((0.0,) * d, upper, 2.0),
        dt=1.0,
        agent_ids=(0,),
        start=[[10.0] * d],
        speed_limits=[1.0],
    )


def test_26_directions_are_unit_vectors_covering_the_neighbourhood() -> None:
    u = directions_26()
    assert u.shape == (26, 3)
    np.testing.assert_allclose(np.linalg.norm(u, axis=1), 1.0)
    o = lattice_offsets(3)
    # every neighbour of a lattice cell exactly once, and nothing else
    cells = {tuple(p) for p in itertools.product((-1, 0, 1), repeat=3)} - {(0, 0, 0)}
    assert {tuple(int(c) for c in row) for row in o} == cells
    np.testing.assert_allclose(o / np.linalg.norm(o, axis=1)[:, None], u)
    assert len({tuple(np.round(r, 12)) for r in u}) == 26
    assert lattice_offsets(2).shape == (8, 2)


def _brute_direction_rewards(w, x, q, targets, position, h1):
    """Eqs. 21-25 with explicit loops over candidates, outcomes and particles."""
    est = sum(w[n] * x[n] for n in range(len(w)))
    h = -sum(w[n] * math.log(w[n]) for n in range(len(w)) if w[n] > 0)
    w_now = math.dist(position, est) + h1 * h
    out = []
    for m in range(len(targets)):
        ew = 0.0
        for z in range(q.shape[1]):
            joint = [w[n] * q[m, z, n] for n in range(len(w))]
            pz = sum(joint)
            if pz <= 0:
                continue
            post = [j / pz for j in joint]
            mean = sum(post[n] * x[n] for n in range(len(w)))
            hz = -sum(p * math.log(p) for p in post if p > 0)
            ew += pz * (math.dist(targets[m], mean) + h1 * hz)
        out.append(w_now - ew)
    return np.array(out)


def test_expected_value_reward_matches_brute_force_enumeration() -> None:
    rng = np.random.default_rng(0)
    x = rng.uniform(0, 20, (30, 3))
    w = rng.random(30)
    w /= w.sum()
    pos = np.array([10.0, 4.0, 10.0])
    targets = pos + 2.0 * lattice_offsets(3)
    model = VergassolaModel().bind(dt=1.0)
    q = model.outcome_probabilities(targets, x)
    for h1 in (0.0, 3.0, 250.0):
        got = direction_rewards(w, x, q, targets, pos, h1)
        np.testing.assert_allclose(
            got, _brute_direction_rewards(w, x, q, targets, pos, h1), rtol=1e-10, atol=1e-10
        )


def test_merging_tail_classes_keeps_the_rewards() -> None:
    rng = np.random.default_rng(1)
    x = rng.uniform(0, 20, (40, 3))
    x[0] = [10.0, 8.0, 10.0]  # one hypothesis at a candidate: the model needs 16 classes
    w = np.full(40, 1 / 40)
    pos = np.array([10.0, 6.0, 10.0])
    targets = pos + 2.0 * lattice_offsets(3)
    q = VergassolaModel().bind(dt=1.0).outcome_probabilities(targets, x)
    assert q.shape[1] == 16
    np.testing.assert_array_equal(merge_tail_classes(w, q, 1e-300), q)
    qm = merge_tail_classes(w, q, 1e-4)
    assert 2 < qm.shape[1] < q.shape[1]
    np.testing.assert_allclose(qm.sum(axis=1), 1.0, rtol=1e-12)
    np.testing.assert_array_equal(qm[:, :-1], q[:, : qm.shape[1] - 1])
    # what moved lies in classes of predicted mass < 1e-4 with values below ~140 m
    np.testing.assert_allclose(
        direction_rewards(w, x, qm, targets, pos, 5.0),
        direction_rewards(w, x, q, targets, pos, 5.0),
        atol=0.02,
    )


def test_step_rewards_count_newly_covered_points() -> None:
    pos = np.zeros(3)
    step = np.array([2.0, 0.0, 0.0])
    est = np.array([20.0, 0.0, 0.0])
    # past points at x = 3 (inside sphere l=2: centre 2, radius 2), x = 5 (l=3: centre 3, r 3)
    hist = np.array([[3.0, 0.0, 0.0], [5.0, 0.5, 0.0], [0.0, 0.0, 0.0], [-3.0, 0.0, 0.0]])
    r = step_rewards(pos, step, 4, est, hist, h2=10.0)
    dist = np.array([18.0, 16.0, 14.0, 12.0])
    # z(1) = 0 (x=3 is 2 from centre 1 > r 1), z(2) = 1, z(3) = 2, z(4) = 2; the current point
    # and the point behind are never counted
    np.testing.assert_allclose(r, dist + 10.0 * np.array([0, 1, 1, 0]))
    np.testing.assert_allclose(step_rewards(pos, step, 4, est, np.zeros((0, 3)), 10.0), dist)
    with pytest.raises(ConfigError):
        step_rewards(pos, step, 0, est, hist, 1.0)


def test_l_max_from_the_source_area_ratio() -> None:
    assert max_step(0.2) == 1
    assert max_step(0.1) == 1
    assert max_step(0.025) == 4  # zeta * l_max = 0.1
    assert max_step(0.03) == 3
    with pytest.raises(ConfigError):
        max_step(0.0)
    model = VergassolaModel().bind(dt=1.0, direction=np.array([0.0, -1.0, 0.0]))
    zeta = source_area_ratio(model, np.zeros(3), np.array([100.0, 60.0, 30.0]), 2.0, 0.1)
    # eq. 26 by hand: the 2 m cells (centres 1, 3, ...) whose chance of at least one encounter
    # in 1 s, 1 - exp(-R dt), reaches 0.1 for a source at the box's centre
    axes = [np.arange(1.0, hi, 2.0) for hi in (100.0, 60.0, 30.0)]
    cells = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    rate = VergassolaModel().rate(cells, [[50.0, 30.0, 15.0]], direction=[0.0, -1.0, 0.0])
    cue = 1.0 - np.exp(-rate[:, 0] * 1.0)
    assert abs(zeta - np.mean(cue >= 0.1)) <= 1.0 / len(cells)  # a cell on the threshold
    assert max_step(zeta) == 4  # the default world's l_max
    # a larger arena around the same plume: a smaller ratio, a longer l_max
    big = source_area_ratio(model, np.zeros(3), np.array([100.0, 200.0, 50.0]), 2.0, 0.1)
    assert big < zeta and max_step(big) > max_step(zeta)


def test_adaptive_planner_goes_towards_a_converged_estimate_in_long_steps() -> None:
    ctx = _ctx()
    planner = AdaptivePathPlanner(AdaptivePlannerParams(l_max=5))
    planner.reset(ctx, VergassolaModel())
    rng = np.random.default_rng(2)
    src = np.array([60.0, 40.0, 20.0])
    x = src + rng.normal(0, 0.5, (100, 3))
    belief = ParticleBelief(x, np.full(100, -math.log(100)))
    pos = np.array([40.0, 40.0, 20.0])
    plan = _plan(planner, belief, pos, [pos], rng, dt=1.0)
    np.testing.assert_allclose(planner.steps[plan.index], [2.0, 0.0, 0.0])
    assert plan.extra["length"] == 5 and plan.extra["l_max"] == 5
    np.testing.assert_allclose(plan.target, [50.0, 40.0, 20.0])
    assert plan.work > 0 and plan.score == plan.scores.min()
    # earlier measurement points only the 5-cell sphere holds (centre 45, radius 5; the
    # 4-cell one ends at x = 48) cost h2 = 0.1 D = 2 m each: R = 18, 16, 14, 12, 10 + 3 * 2
    other = AdaptivePathPlanner(AdaptivePlannerParams(l_max=5))
    other.reset(ctx, VergassolaModel())
    hist = np.array([pos, [49.0, 40.0, 20.0], [49.5, 40.0, 20.0], [49.5, 40.5, 20.0]])
    short = _plan(other, belief, pos, hist, rng, dt=1.0)
    assert short.extra["length"] == 4
    np.testing.assert_allclose(short.target, [48.0, 40.0, 20.0])


def test_a_step_planner_needs_a_measurement_model() -> None:
    with pytest.raises(ConfigError, match=r"^model: "):
        AdaptivePathPlanner().reset(_ctx())


def test_planners_stay_inside_the_arena() -> None:
    ctx = _ctx()
    rng = np.random.default_rng(3)
    x = rng.uniform([0, 0, 0], [100, 60, 30], (80, 3))
    belief = ParticleBelief(x, np.full(80, -math.log(80)))
    corner = np.array([0.0, 0.0, 0.0])
    for planner in (AdaptivePathPlanner(), FixedStepInfotaxis()):
        planner.reset(ctx, VergassolaModel())
        plan = _plan(planner, belief, corner, [corner], rng, dt=1.0)
        assert plan.target is not None
        assert ctx.arena.is_free(plan.target[None])[0]
        assert not plan.feasible[0]  # (-1, -1, -1) leaves the box
        assert plan.scores[0] == np.inf


def test_found_outcome_makes_a_probability_distribution() -> None:
    rng = np.random.default_rng(4)
    x = rng.uniform(0, 10, (50, 3))
    targets = rng.uniform(0, 10, (6, 3))
    q = censored_poisson(rng.uniform(0, 2, (6, 50)), 4).transpose(0, 2, 1)
    qf = with_found_outcome(q, targets, x, 2.0)
    np.testing.assert_allclose(qf.sum(axis=1), 1.0)
    near = np.linalg.norm(targets[:, None] - x[None], axis=2) <= 2.0
    np.testing.assert_array_equal(qf[:, -1, :] == 1.0, near)
    # expected posterior entropy against Bayes' rule class by class, from a non-uniform prior
    lw = rng.normal(0.0, 1.0, 50)
    lw -= math.log(np.exp(lw).sum())
    eh = expected_entropy(lw, qf)
    np.testing.assert_allclose(eh, _brute_expected_entropy(np.exp(lw), qf), rtol=1e-10)
    # a found radius covering every particle: 'found' is certain and leaves the prior as it is
    qall = with_found_outcome(q, targets, x, 100.0)
    prior = -float(np.exp(lw) @ lw)
    np.testing.assert_allclose(expected_entropy(lw, qall), prior, rtol=1e-12)
    assert np.all(eh < prior)  # a measurement that can tell hypotheses apart informs


def _brute_expected_entropy(w: np.ndarray, q: np.ndarray) -> np.ndarray:
    """``sum_z P(z) H(w | z)`` with explicit loops (Bayes' rule per outcome class)."""
    out = []
    for m in range(q.shape[0]):
        acc = 0.0
        for z in range(q.shape[1]):
            joint = [w[n] * q[m, z, n] for n in range(len(w))]
            pz = sum(joint)
            if pz > 0:
                acc += pz * -sum(j / pz * math.log(j / pz) for j in joint if j > 0)
        out.append(acc)
    return np.array(out)


def test_fixed_step_infotaxis_takes_the_least_expected_entropy() -> None:
    ctx = _ctx((40.0, 40.0, 40.0))
    planner = FixedStepInfotaxis()
    planner.reset(ctx, VergassolaModel())
    rng = np.random.default_rng(5)
    x = rng.uniform(0, 40, (120, 3))
    belief = ParticleBelief(x, np.full(120, -math.log(120)))
    pos = np.array([20.0, 20.0, 20.0])
    model = VergassolaModel().bind(dt=1.0)
    plan = _plan(planner, belief, pos, [pos], rng, dt=1.0)
    assert plan.extra["length"] == 1
    assert plan.score == pytest.approx(np.min(plan.scores), rel=1e-9)
    np.testing.assert_allclose(plan.target, pos + planner.steps[plan.index])
    # the scores themselves, from a belief that prefers one side, against Bayes' rule by hand:
    # every count class (none merged) conditioned on not found, and the found class
    for backend in ("numpy", "numba"):
        exact = FixedStepInfotaxis(FixedStepParams(tail_mass=1e-300, ties="first", backend=backend))
        exact.reset(ctx, VergassolaModel())
        lw = -0.5 * np.sum((x - [30.0, 25.0, 20.0]) ** 2, axis=1) / 36.0
        lw -= math.log(np.exp(lw).sum())
        skewed = ParticleBelief(x, lw)
        got = _plan(exact, skewed, pos, [pos], rng, dt=1.0)
        targets = pos + exact.steps
        q = model.outcome_probabilities(targets, x)
        ref = _brute_expected_entropy(np.exp(lw), with_found_outcome(q, targets, x, 2.0))
        np.testing.assert_allclose(got.scores, ref, rtol=1e-9)
        assert got.index == int(np.argmin(ref))
        # the directions differ clearly, so the choice is the reward's and not a tie's
        assert np.ptp(ref) > 0.1
