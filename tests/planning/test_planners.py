"""The planner family: the contract over every member, and its parts (candidates, selection,
rewards) composed by configuration."""

from __future__ import annotations

import math

import numpy as np
import pytest

from odorloc import checks
from odorloc.core import registry
from odorloc.core.errors import ConfigError
from odorloc.core.types import SearchContext
from odorloc.geometry.arena import Arena
from odorloc.inference.belief import ParticleBelief
from odorloc.planning.base import Plan, Pose
from odorloc.planning.candidates import CandidateSet, MoveCandidates
from odorloc.planning.infotaxis import ParticlePlanner
from odorloc.planning.selection import BestSelection


@pytest.mark.parametrize("name", registry.names("planner"))
def test_every_planner(name: str) -> None:
    report = checks.check_planner(name)
    cls = registry.entry("planner", name).build
    for d in cls.dims:
        assert f"{d}D (" in report


class Shuffled(ParticlePlanner):
    """A broken member: its choice is drawn from a stream of its own."""

    def plan(self, belief, pose, rng):  # type: ignore[no-untyped-def]
        p = super().plan(belief, pose, rng)
        m = len(p.candidates)
        return Plan(int(np.random.default_rng().integers(m)), p.candidates, p.scores, p.feasible)


class Outside(ParticlePlanner):
    """A broken member: its candidates lie 100 m away and it calls them feasible."""

    def plan(self, belief, pose, rng):  # type: ignore[no-untyped-def]
        p = super().plan(belief, pose, rng)
        m = len(p.candidates)
        return Plan(0, p.candidates + 100.0, np.zeros(m), np.ones(m, bool))


@pytest.mark.parametrize(("cls", "what"), [(Shuffled, "per seed"), (Outside, "outside")])
def test_the_planner_check_catches_a_broken_member(cls: type, what: str) -> None:
    with pytest.raises(checks.ContractError, match=what):
        checks.check_planner(f"{__name__}:{cls.__name__}", dims=(2,))


def _ctx(arena: Arena) -> SearchContext:
    start = np.atleast_2d(arena.lo + 0.5 * arena.size)
    return SearchContext(arena=arena, dt=0.5, agent_ids=(0,), start=start, speed_limits=[0.4])


def test_move_candidates_follow_the_frame_and_the_walls() -> None:
    arena = Arena.box((0, 0), (4, 4), 0.1).with_boxes([((2.3, 0.0), (2.5, 4.0))])
    c = MoveCandidates(registry.make_params("candidates", "moves", {"frame": "world"}))
    c.reset(_ctx(arena))
    cs = c.generate(None, Pose(np.array([2.0, 2.0])))
    assert isinstance(cs, CandidateSet)
    # one control period at the speed limit: 0.2 m forward (+x), backward, left (+y), right
    np.testing.assert_allclose(cs.targets, [[2.2, 2.0], [1.8, 2.0], [2.0, 2.2], [2.0, 1.8]])
    assert cs.feasible.tolist() == [True] * 4
    far = c.generate(None, Pose(np.array([2.15, 2.0])))  # forward now ends in the wall
    assert far.feasible.tolist() == [False, True, True, True]


def test_best_selection_ties() -> None:
    s = np.array([1.0, 0.5, 0.5 + 1e-9, np.inf])
    first = BestSelection(registry.make_params("selection", "best", {}))
    assert first.choose(s, np.ones(4, bool), None) == 1
    tol = BestSelection(registry.make_params("selection", "best", {"tolerance": 1e-6}))
    assert tol.tolerance == 1e-6
    draws = {
        BestSelection(
            registry.make_params("selection", "best", {"ties": "random", "tolerance": 1e-6})
        ).choose(s, np.ones(4, bool), np.random.default_rng(k))
        for k in range(30)
    }
    assert draws == {1, 2}
    assert first.choose(s, np.array([True, False, False, True]), None) == 0
    assert first.choose(s, np.zeros(4, bool), None) is None


def test_rewards_are_configured_not_subclassed() -> None:
    """Every infotaxis-family policy is one planner class with another reward part."""
    belief = ParticleBelief(
        np.array([[1.0, 2.0], [1.0, -3.0]]), np.log([0.5, 0.5]), found_radius=0.5
    )
    ctx = _ctx(Arena.box((-5, -5), (5, 5), 0.1))
    scores = {}
    for reward in ("expected-entropy", "predictive-entropy", "greedy", "mean-distance"):
        params = {"candidates": {"moves": "lattice", "step": 2.0}, "reward": {"type": reward}}
        p = registry.entry("planner", "particle").build(
            registry.make_params("planner", "particle", params)
        )
        assert type(p) is ParticlePlanner
        p.reset(ctx, registry.ComponentRef(type="vergassola").build("model"))
        pose = Pose(np.array([1.0, 0.0]), conditions={"dt": 1.0, "n_classes": 2})
        plan = p.plan(belief, pose, np.random.default_rng(0))
        scores[reward] = plan
    # +y (index 3) lands on the first particle: found with probability 1/2
    assert scores["greedy"].index == 3 and scores["greedy"].score == pytest.approx(0.5)
    # the mean distance of the particle not found there: 5 m, half the weight
    md = scores["mean-distance"].scores
    assert md[3] == pytest.approx(0.5 * 5.0)
    assert all(math.isfinite(v) for v in scores["expected-entropy"].scores)
    with pytest.raises(ConfigError) as ei:
        registry.make_params("planner", "particle", {"reward": {"type": "infotaxis"}})
    assert ei.value.field == "reward.type"
