"""The compiled whole lattice step against its NumPy reference and the lattice planner."""

from __future__ import annotations

import numpy as np
import pytest

from odorloc.core.errors import ConfigError
from odorloc.core.types import SearchContext
from odorloc.geometry.arena import Arena
from odorloc.geometry.grid import CellGrid
from odorloc.inference.grid_estimator import LatticeBelief
from odorloc.models.lattice import (
    IsotropicHitModel,
    IsotropicHitParams,
    initial_belief,
    isotropic_mean_hits,
    tabulate,
)
from odorloc.models.poisson import censored_poisson
from odorloc.planning.base import Pose
from odorloc.planning.infotaxis import LatticePlanner, LatticePlannerParams
from odorloc.planning.lattice_step import (
    POLICIES,
    LatticeKernels,
    draw_hit,
    log_belief,
    observe,
    scores,
    scores_numpy,
    search_step,
    step_numpy,
)


def _table(dim: int, n: int, length: float = 2.0, intensity: float = 2.0):
    model = IsotropicHitModel(IsotropicHitParams(length=length, intensity=intensity))
    return model, tabulate(model, 1.0, (n - 1,) * dim)


def _start(dim: int, n: int, table, h0: int = 1) -> np.ndarray:
    """OTTO's first belief after the hit ``h0`` at the centre."""
    grid = np.stack(np.meshgrid(*[np.arange(n)] * dim, indexing="ij"), -1)
    d = np.linalg.norm(grid - n // 2, axis=-1)
    z = table.n_classes
    mu = isotropic_mean_hits(d.reshape(-1), 2.0, 2.0, 1.0, dim)
    like = censored_poisson(mu, z)[:, h0].reshape((n,) * dim)
    return initial_belief(like, (n // 2,) * dim, np.ones((n,) * dim, bool))


def _episode_states(k: LatticeKernels, b0: np.ndarray, steps: int, seed: int):
    """Beliefs and agents along a NumPy-reference episode (source drawn from ``b0``)."""
    rng = np.random.default_rng(seed)
    n = b0.shape[-1]
    src = np.array(np.unravel_index(rng.choice(b0.size, p=b0.reshape(-1)), b0.shape))
    ag = np.full(k.dim, n // 2)
    b = k.as_kernel(b0.copy())
    out = []
    for _ in range(steps):
        out.append((b.copy(), ag.copy()))
        _, h, ag3, b = step_numpy(k, b, ag, src, rng.random())
        ag = ag3[3 - k.dim :]
        if h < 0:
            break
    return out


@pytest.mark.parametrize("policy", sorted(POLICIES))
@pytest.mark.parametrize("dim,n", [(2, 15), (3, 7)])
def test_compiled_step_equals_numpy_reference(policy: str, dim: int, n: int) -> None:
    _, t = _table(dim, n)
    k = LatticeKernels(t.prob, policy)
    b0 = _start(dim, n, t)
    for seed in (0, 1):
        rng = np.random.default_rng(100 + seed)
        src = np.array(np.unravel_index(rng.choice(b0.size, p=b0.reshape(-1)), b0.shape))
        b_ref = k.as_kernel(b0.copy())
        b = b_ref.copy()
        logb, ent = log_belief(k, b)
        pos = b[b > 1e-10]
        assert ent == pytest.approx(float(-(pos * np.log2(pos)).sum()), rel=1e-13)
        ag = k.agent3(np.full(dim, n // 2)).copy()
        ag_ref = ag[3 - dim :].copy()
        for _ in range(12):
            u = rng.random()
            ref_scores = scores_numpy(k, b_ref, ag_ref)
            sc = np.empty(2 * dim)
            a, h, ent = search_step(k, b, logb, ent, ag, k.agent3(src), u, scores=sc)
            a_ref, h_ref, ag3, b_ref = step_numpy(k, b_ref, ag_ref, src, u)
            assert (a, h) == (a_ref, h_ref)
            finite = np.isfinite(ref_scores)
            np.testing.assert_array_equal(np.isfinite(sc), finite)
            np.testing.assert_allclose(sc[finite], ref_scores[finite], rtol=1e-11, atol=1e-12)
            np.testing.assert_array_equal(ag, ag3)
            if h < 0:
                break
            np.testing.assert_allclose(b, b_ref, rtol=1e-12, atol=1e-300)
            pos = b_ref[b_ref > 1e-10]
            assert ent == pytest.approx(float(-(pos * np.log2(pos)).sum()), rel=1e-12)
            ag_ref = ag3[3 - dim :]


@pytest.mark.parametrize("policy", ["infotaxis", "greedy", "mean-distance"])
def test_choices_equal_the_lattice_planner(policy: str) -> None:
    """Same move as the engine's lattice planner (its NumPy backend) on episode beliefs."""
    n = 15
    model, t = _table(2, n)
    k = LatticeKernels(t.prob, policy)
    states = _episode_states(k, _start(2, n, t), 25, seed=3)
    grid = CellGrid((0.0, 0.0), 1.0, (n, n))
    arena = Arena.box((0.0, 0.0), (float(n), float(n)), 1.0)
    ctx = SearchContext(arena, 1.0, (0,), np.zeros((1, 2)), np.ones(1))
    planner = LatticePlanner(LatticePlannerParams(reward={"type": _reward(policy)}))
    planner.reset(ctx, model)
    rng = np.random.default_rng(0)
    assert len(states) > 5
    for b, ag in states:
        prob = b.reshape(n, n)
        belief = LatticeBelief(grid, prob, {}, prob[None], (t,), 0.5)
        plan = planner.plan(belief, Pose(grid.center(ag)[0]), rng)
        target = grid.index(plan.target)[0]
        scores = scores_numpy(k, b, ag)
        a = int(np.flatnonzero(np.abs(scores - scores.min()) < 1e-10)[0])
        moved = ag.copy()
        moved[a // 2] += 1 if a % 2 else -1
        np.testing.assert_array_equal(moved, target)


def _reward(policy: str) -> str:
    return {"infotaxis": "expected-entropy", "greedy": "greedy", "mean-distance": "mean-distance"}[
        policy
    ]


def test_first_move_ties_and_otto_check_values() -> None:
    """At the start every move ties by symmetry (move 0 is taken); the compiled scores equal
    the NumPy ones; entropy and first-move expected entropy decrease are OTTO's check values
    for 2-D, L = 2, I = 2, h0 = 1 (N = 37)."""
    n = 37
    _, t = _table(2, n)
    k = LatticeKernels(t.prob, "infotaxis")
    b = k.as_kernel(_start(2, n, t))
    ag = np.array([n // 2, n // 2])
    ref = scores_numpy(k, b, ag)
    logb, ent = log_belief(k, b)
    assert ent == pytest.approx(7.58876320501, abs=1e-9)
    assert -ref[0] == pytest.approx(0.3164586363, abs=1e-9)
    a, sc = scores(k, b, logb, ent, ag)
    np.testing.assert_allclose(sc, ref, rtol=0, atol=1e-12)
    assert a == 0
    src = k.agent3(ag + np.array([5, 0]))
    a, _, _ = search_step(k, b.copy(), logb, ent, k.agent3(ag), src, 0.5)
    assert a == 0


def test_hit_law_is_the_table() -> None:
    """Inverting the cumulative law at uniform numbers gives the tabulated frequencies."""
    _, t = _table(2, 9)
    k = LatticeKernels(t.prob)
    ag, src = np.array([4, 4]), np.array([5, 6])
    u = (np.arange(20000) + 0.5) / 20000
    counts = np.bincount([draw_hit(k, ag, src, v) for v in u], minlength=k.n_classes)
    expected = t.prob[:, 8 + 1, 8 + 2]
    np.testing.assert_allclose(counts / u.size, expected, atol=1e-4)


def test_bad_input() -> None:
    with pytest.raises(ConfigError, match="policy"):
        LatticeKernels(np.ones((2, 3, 3)) / 2, "fastest")
    with pytest.raises(ConfigError, match="prob"):
        LatticeKernels(np.ones((2, 4, 4)) / 2)
    k = LatticeKernels(np.ones((2, 3, 3)) / 2)
    b = np.full(k.shape, 0.25)
    with pytest.raises(ConfigError, match="hit"):
        observe(k, b, np.log(b), np.array([0, 0]), 2)
