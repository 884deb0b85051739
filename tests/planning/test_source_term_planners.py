"""Planners over a source-term posterior: scores against brute force, feasibility, the route."""

from __future__ import annotations

import math

import numpy as np
import pytest

from odorloc.core.errors import ConfigError
from odorloc.core.types import SearchContext, SensorInfo
from odorloc.geometry.arena import Arena
from odorloc.inference.source_terms import SourceTermBelief
from odorloc.models.source_term import (
    GaussianSourceTermModel,
    GaussianSourceTermParams,
    ThetaLayout,
)
from odorloc.planning.base import Pose
from odorloc.planning.source_term import (
    LawnmowerParams,
    LawnmowerPlanner,
    SourceTermEntrotaxis,
    SourceTermInfotaxis,
    SourceTermPlannerParams,
    candidate_directions,
)

WIND = np.array([1.0, 0.3])


def _ctx(arena: Arena | None = None, start: tuple[float, float] = (12.0, 10.0)) -> SearchContext:
    return SearchContext(
        arena=arena or Arena.box([0, 0], [30, 20], 0.25),
        dt=1.0,
        agent_ids=(0,),
        start=np.array([start]),
        speed_limits=np.array([2.0]),
        sensor=SensorInfo(threshold=0.2),
        search_region=((2.0, 2.0), (28.0, 18.0)),
    )


def _belief(n: int = 60, seed: int = 0) -> SourceTermBelief:
    rng = np.random.default_rng(seed)
    th = np.column_stack([rng.uniform(2, 14, n), rng.uniform(6, 14, n), rng.normal(0.0, 0.5, n)])
    return SourceTermBelief.of(th, rng.normal(0, 0.3, n), ThetaLayout(2))


def _model() -> GaussianSourceTermModel:
    return GaussianSourceTermModel(
        GaussianSourceTermParams(K=0.2, sigma0=0.3, noise_std=0.2, threshold=0.2, miss=0.1)
    )


@pytest.mark.parametrize("policy", ["infotaxis", "entrotaxis"])
@pytest.mark.parametrize("n", [4, 8, 16])
def test_scores_are_the_entropies_of_the_outcome_law(policy: str, n: int) -> None:
    """Each candidate's score is the brute-force (expected posterior / predictive) entropy over
    the thinned particles and the model's outcome classes."""
    cls = SourceTermInfotaxis if policy == "infotaxis" else SourceTermEntrotaxis
    planner = cls(SourceTermPlannerParams(directions=n, n_plan=40))
    model = _model()
    planner.reset(_ctx(), model)
    belief = _belief()
    pose = Pose(np.array([12.0, 10.0]), conditions={"wind": WIND, "dt": 1.0})
    plan = planner.plan(belief, pose, np.random.default_rng(0))
    assert plan.candidates.shape == (n, 2) and plan.feasible.all()
    np.testing.assert_allclose(
        np.linalg.norm(plan.candidates - pose.position, axis=1), 2.0, rtol=1e-12
    )
    terms, _ = belief.thin(40)
    q = model.outcome_probabilities(plan.candidates, terms, wind=WIND)
    for m in range(n):
        pz = q[m].mean(axis=1)
        if policy == "entrotaxis":
            want = sum(p * math.log(p) for p in pz if p > 0)
        else:
            want = 0.0
            for zc in range(q.shape[1]):
                post = q[m, zc] / q[m, zc].sum() if q[m, zc].sum() > 0 else np.zeros(40)
                ent = -sum(p * math.log(p) for p in post if p > 0)
                want += pz[zc] * ent
        assert plan.scores[m] == pytest.approx(want, abs=1e-10)
    assert plan.index == int(np.argmin(plan.scores))
    assert plan.work == q.size


def test_walls_make_candidates_infeasible() -> None:
    arena = Arena.box([0, 0], [30, 20], 0.25).with_boxes([((13.0, 0.0), (14.0, 20.0))])
    planner = SourceTermEntrotaxis(SourceTermPlannerParams(directions=8, n_plan=30))
    planner.reset(_ctx(arena), _model())
    plan = planner.plan(
        _belief(), Pose(np.array([12.0, 10.0]), conditions={"wind": WIND}), np.random.default_rng(0)
    )
    east = plan.candidates[:, 0] > 12.5
    assert not plan.feasible[east].any() and plan.feasible[~east].all()
    assert np.isinf(plan.scores[east]).all()
    assert plan.index is not None and not east[plan.index]


def test_3d_candidates_add_up_and_down() -> None:
    u = candidate_directions(16, 3, vertical=True)
    assert u.shape == (18, 3)
    np.testing.assert_allclose(np.linalg.norm(u, axis=1), 1.0)
    assert candidate_directions(4, 2, vertical=True).shape == (4, 2)


def test_lawnmower_gives_out_its_route_then_nothing() -> None:
    planner = LawnmowerPlanner(LawnmowerParams(spacing=5.0, along="y", margin=1.0, rounds=2))
    planner.reset(_ctx(start=(3.0, 3.0)))
    wp = planner.waypoints
    assert wp[0, 0] == pytest.approx(3.0) and wp[0, 1] == pytest.approx(3.0)
    lo, hi = np.array([3.0, 3.0]), np.array([27.0, 17.0])
    assert np.all(wp >= lo - 1e-9) and np.all(wp <= hi + 1e-9)
    got = []
    while True:
        plan = planner.plan(None, Pose(np.zeros(2)), np.random.default_rng(0))
        if plan.index is None:
            break
        got.append(plan.target)
    np.testing.assert_array_equal(np.array(got), wp)
    assert planner.done and planner.length > 2 * (4 * 14 + 24)


def test_planners_refuse_what_they_cannot_use() -> None:
    with pytest.raises(ConfigError, match="model"):
        SourceTermInfotaxis().reset(_ctx(), None)
    with pytest.raises(ConfigError, match="margin"):
        LawnmowerPlanner(LawnmowerParams(margin=20.0)).reset(_ctx())
    with pytest.raises(ValueError, match="directions"):
        SourceTermPlannerParams(directions=2)
