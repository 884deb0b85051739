"""Rewards with the found outcome and the infotaxis-family planners: against brute force on tiny
problems and against a direct implementation of the reference (OTTO) conventions on constructed
beliefs, for every policy."""

from __future__ import annotations

import math

import numpy as np
import pytest

from odorloc.core.errors import ConfigError
from odorloc.core.registry import make_params
from odorloc.core.types import SearchContext
from odorloc.geometry.arena import Arena
from odorloc.geometry.grid import CellGrid
from odorloc.inference.belief import ParticleBelief
from odorloc.inference.grid_estimator import LatticeBelief
from odorloc.inference.grid_filter import GridFilter
from odorloc.models.base import MeasurementModel, binary_outcomes
from odorloc.models.lattice import IsotropicHitModel, IsotropicHitParams, tabulate
from odorloc.papers.infotaxis.reference import CHECKS
from odorloc.planning import infotaxis as inf
from odorloc.planning import rewards
from odorloc.planning.base import Plan, Pose
from odorloc.planning.candidates import neighbour_cells

EPS = 1e-10
REWARD = {
    "infotaxis": "expected-entropy",
    "space-aware": "space-aware",
    "greedy": "greedy",
    "mean-distance": "mean-distance",
    "entrotaxis": "predictive-entropy",
}


def _ctx(lower, upper, start, blocked=()) -> SearchContext:
    arena = Arena.box(lower, upper, 1.0)
    if blocked:
        arena = arena.with_boxes(blocked)
    return SearchContext(
        arena=arena,
        dt=1.0,
        agent_ids=(0,),
        start=np.atleast_2d(start),
        speed_limits=np.ones(1),
    )


def _lattice_plan(
    policy: str,
    b: np.ndarray,
    tables: list,
    cell: tuple[int, ...],
    *,
    ties: str = "first",
    floor: float = EPS,
    blocked: tuple[tuple[int, ...], ...] = (),
    rng: np.random.Generator | None = None,
) -> Plan:
    """The lattice planner with ``policy`` on the joint belief ``b`` (``(K, *shape)`` or
    ``shape``) from ``cell`` of a unit grid at the origin; ``blocked`` cells are obstacles."""
    joint = np.asarray(b, float)
    if joint.ndim == tables[0].dim:
        joint = joint[None]
    shape = joint.shape[1:]
    d = len(shape)
    grid = CellGrid((0.0,) * d, 1.0, shape)
    here = grid.center(np.array(cell))[0]
    boxes = [(tuple(float(v) for v in c), tuple(float(v) + 1.0 for v in c)) for c in blocked]
    ctx = _ctx((0.0,) * d, tuple(float(n) for n in shape), here, boxes)
    params = {
        "reward": {"type": REWARD[policy]},
        "selection": {"ties": ties, "tolerance": EPS},
        "floor": floor,
    }
    planner = inf.LatticePlanner(make_params("planner", "lattice", params))
    planner.reset(ctx)
    belief = LatticeBelief(grid, joint.sum(axis=0), {}, joint, tuple(tables), 0.5)
    return planner.plan(belief, Pose(here), rng or np.random.default_rng(0))


def _brute(w: np.ndarray, q: np.ndarray, found: np.ndarray) -> dict[str, np.ndarray]:
    """Expected entropy, predictive entropy, mean distance ingredients by enumeration (nats)."""
    m, z, _ = q.shape
    eh, ph = np.zeros(m), np.zeros(m)
    for k in range(m):
        pe = w[found[k]].sum()
        h_out = -pe * math.log(pe) if pe > 0 else 0.0
        for c in range(z):
            joint = w * (~found[k]) * q[k, c]
            pz = joint.sum()
            if pz > 0:
                post = joint / pz
                nz = post > 0
                eh[k] += pz * -np.sum(post[nz] * np.log(post[nz]))
                h_out -= pz * math.log(pz)
        ph[k] = h_out
    return {"expected": eh, "predictive": ph}


def _problem(seed: int, m: int = 4, z: int = 3, n: int = 12) -> tuple:
    rng = np.random.default_rng(seed)
    w = rng.dirichlet(np.ones(n) * 0.5)
    q = rng.dirichlet(np.ones(z), size=(m, n)).transpose(0, 2, 1)
    found = rng.random((m, n)) < 0.15
    return w, q, found


@pytest.mark.parametrize("seed", range(5))
def test_entropies_with_the_found_outcome_match_brute_force(seed: int) -> None:
    w, q, found = _problem(seed)
    ref = _brute(w, q, found)
    lw = np.log(w)
    np.testing.assert_allclose(rewards.expected_entropy(lw, q, found), ref["expected"], rtol=1e-12)
    np.testing.assert_allclose(
        rewards.expected_entropy(lw, q, found, unit="bits"), ref["expected"] / math.log(2)
    )
    np.testing.assert_allclose(rewards.predictive_entropy(lw, q, found), ref["predictive"])
    # the floor path (explicit posteriors) agrees with the one-pass formula up to the floor
    np.testing.assert_allclose(
        rewards.expected_entropy(lw, q, found, floor=1e-300), ref["expected"], rtol=1e-10
    )
    # without found outcomes the formulas reduce to the plain ones
    np.testing.assert_allclose(
        rewards.expected_entropy(lw, q, np.zeros_like(found)), rewards.expected_entropy(lw, q)
    )


def test_found_outcome_closed_forms() -> None:
    lw = np.log([0.5, 0.5])
    useless = np.full((1, 2, 2), 0.5)
    # finding the source with probability 1/2 leaves the other half certain: entropy 0
    assert rewards.expected_entropy(lw, useless, np.array([[True, False]]))[0] == pytest.approx(0)
    # outcome entropy: found (1/2) and the two readings (1/4 each): 1.5 bits
    h = rewards.predictive_entropy(lw, useless, np.array([[True, False]]), unit="bits")
    assert h[0] == pytest.approx(1.5)
    assert rewards.greedy(lw, np.array([[True, False], [False, False]])).tolist() == [0.5, 1.0]


def test_mean_distance_is_the_prior_mean_distance() -> None:
    w, q, found = _problem(7)
    d = np.random.default_rng(3).random(found.shape) * 5
    md = rewards.mean_distance(np.log(w), q, found, d)
    np.testing.assert_allclose(md, ((~found) * w * d).sum(axis=1), rtol=1e-12)


def test_space_aware_value_by_hand() -> None:
    # two hypotheses, a reading that tells them apart: each posterior is certain (S = 0 bits),
    # so g(D + 2^-1 - 1/2) = log2(D) with D the distance of that hypothesis
    lw = np.log([0.5, 0.5])
    q = np.array([[[1.0, 0.0], [0.0, 1.0]]])
    d = np.array([[2.0, 4.0]])
    v = rewards.space_aware_value(lw, q, None, d)
    assert v[0] == pytest.approx(0.5 * math.log2(2.0) + 0.5 * math.log2(4.0))


def test_rewards_bad_input() -> None:
    with pytest.raises(ConfigError, match="outcome_probs"):
        rewards.expected_entropy(np.zeros(3), np.ones((2, 3)))
    with pytest.raises(ConfigError, match="found"):
        rewards.expected_entropy(np.zeros(3), np.ones((2, 1, 3)), np.ones((2, 2), bool))
    with pytest.raises(ConfigError, match="unit"):
        rewards.expected_entropy(np.zeros(3), np.ones((2, 1, 3)), unit="bans")  # type: ignore[arg-type]
    with pytest.raises(ConfigError, match="distances"):
        rewards.mean_distance(np.zeros(3), np.ones((2, 1, 3)), None, np.ones((3, 3)))


# ---------------------------------------------------------------------- reference conventions
def _otto_scores(policy: str, b: np.ndarray, agent: tuple[int, int], table) -> np.ndarray:
    """The reference implementation's scores written out candidate by candidate (the note's
    definitions: normalise above 1e-10, entropies over entries above 1e-10, bits)."""
    n = b.shape[0]
    z = table.n_classes
    h = table.half[0]
    idx = np.stack(np.meshgrid(np.arange(n), np.arange(n), indexing="ij"), -1)

    def ent(p: np.ndarray) -> float:
        k = p > EPS
        return float(-np.sum(p[k] * np.log2(p[k])))

    out = []
    for move in ((-1, 0), (1, 0), (0, -1), (0, 1)):
        c = (agent[0] + move[0], agent[1] + move[1])
        if not (0 <= c[0] < n and 0 <= c[1] < n):
            out.append(np.inf)
            continue
        pe = b[c]
        if policy == "greedy":
            out.append(1.0 - pe)
            continue
        if pe > 1 - EPS:
            out.append(-EPS - ent(b) if policy == "infotaxis" else -EPS)
            continue
        bp = b.copy()
        bp[c] = 0.0
        if bp.sum() > EPS:
            bp /= bp.sum()
        like = table.prob[:, h - c[0] : h - c[0] + n, h - c[1] : h - c[1] + n].copy()
        like[:, c[0], c[1]] = 0.0
        post = bp[None] * like
        p = post.sum(axis=(1, 2))
        for k in range(z):
            if p[k] > EPS:
                post[k] /= p[k]
        dist = np.abs(idx - np.array(c)).sum(-1)
        if policy == "infotaxis":
            out.append((1 - pe) * sum(p[k] * ent(post[k]) for k in range(z)) - ent(b))
        elif policy == "space-aware":
            v = 0.0
            for k in range(z):
                val = np.sum(post[k] * dist) + 2 ** (ent(post[k]) - 1) - 0.5
                v += (1 - pe) * p[k] * (math.log2(val) if val > 0 else val)
            out.append(v)
        elif policy == "mean-distance":
            out.append((1 - pe) * sum(p[k] * np.sum(post[k] * dist) for k in range(z)))
        else:  # entrotaxis: entropy of the outcome (found, or a reading)
            joint = (1 - pe) * p
            hh = -pe * math.log2(pe) if pe > 0 else 0.0
            out.append(-(hh - sum(x * math.log2(x) for x in joint if x > 0)))
    return np.array(out)


def _otto_choice(scores: np.ndarray) -> int:
    return int(np.flatnonzero(np.abs(scores - scores.min()) < EPS)[0])


def _beliefs(n: int, seed: int, table) -> list[tuple[np.ndarray, tuple[int, int]]]:
    """Beliefs of a searcher after a few readings (heavy tails of tiny cells) and some sharp
    ones, at the centre and at edges and corners."""
    rng = np.random.default_rng(seed)
    grid = CellGrid((0.0, 0.0), 1.0, (n, n))
    out = []
    for _ in range(6):
        f = GridFilter(grid)
        a = (n // 2, n // 2)
        for _ in range(int(rng.integers(1, 12))):
            a = (int(np.clip(a[0] + rng.integers(-1, 2), 0, n - 1)), int(a[1]))
            a = (a[0], int(np.clip(a[1] + rng.integers(-1, 2), 0, n - 1)))
            f.exclude_near(grid.center(a)[0], 0.5)
            f.observe_table([table], int(rng.integers(0, table.n_classes)), a)
        out.append((f.prob.copy(), a))
    sharp = rng.dirichlet(np.full(n * n, 0.05)).reshape(n, n)
    for a in ((0, 0), (n - 1, n // 2), (1, n - 1)):
        s = sharp.copy()
        s[a] = 0.0
        out.append((s / s.sum(), a))
    sym = np.ones((n, n))
    sym[n // 2, n // 2] = 0
    out.append((sym / sym.sum(), (n // 2, n // 2)))
    return out


@pytest.mark.parametrize(
    "policy", ["infotaxis", "space-aware", "greedy", "mean-distance", "entrotaxis"]
)
@pytest.mark.parametrize("setting", [(1.0, 1.0, 19), (2.0, 2.0, 37)])
def test_choices_are_the_reference_choices(policy: str, setting: tuple) -> None:
    L, intensity, n = setting
    table = tabulate(
        IsotropicHitModel(IsotropicHitParams(length=L, intensity=intensity)), 1.0, (n - 1, n - 1)
    )
    for b, a in _beliefs(n, 11, table):
        ref = _otto_scores(policy, b, a, table)
        plan = _lattice_plan(policy, b, [table], a)
        assert plan.index == _otto_choice(ref), (policy, a)
        fin = np.isfinite(ref)
        # exact ties are not rescored: their scores may differ by the conventions' bound
        bound = b.size * EPS * math.log2(1 / EPS) + 1e-8
        np.testing.assert_allclose(plan.scores[fin], ref[fin], atol=bound)
        assert not np.isfinite(plan.scores[~fin]).any()


@pytest.mark.parametrize("key", list(CHECKS))
def test_first_move_gain_check_values(key: str) -> None:
    ref = CHECKS[key]
    n = ref["n_grid"]
    L = 1.0 if n == 19 else 2.0
    table = tabulate(
        IsotropicHitModel(IsotropicHitParams(length=L, intensity=L)), 1.0, (n - 1, n - 1)
    )
    f = GridFilter(CellGrid((0.0, 0.0), 1.0, (n, n)))
    c = (n // 2, n // 2)
    f.exclude_near(f.grid.center(c)[0], 0.5)
    f.observe_table([table], 1, c)
    assert f.entropy() == pytest.approx(ref["entropy_b0"], abs=1e-9)
    assert f.prob[c[0] - 1, c[1]] == pytest.approx(ref["b0_neighbour"], abs=1e-11)
    cells = neighbour_cells(c)
    plan = _lattice_plan("infotaxis", f.joint, [table], c)
    assert plan.index == 0  # every move ties by symmetry: the first one
    # the exact information differs from the reference's truncated entropies by < 1e-7 here
    np.testing.assert_allclose(plan.scores, -ref["first_move_gain"], atol=1e-7)
    # with the reference conventions the check value is met to its printed digits
    pe, p, s, _ = inf.lattice_posteriors(f.joint, [table], cells, 0.5, EPS)
    keep = f.prob > EPS
    s0 = -np.sum(f.prob[keep] * np.log2(f.prob[keep]))
    gain = s0 - rewards.expected_entropy_from(pe, p, s, EPS)
    np.testing.assert_allclose(gain, ref["first_move_gain"], atol=1e-9)


def test_fast_and_explicit_outcomes_agree() -> None:
    table = tabulate(IsotropicHitModel(IsotropicHitParams(length=2.0, intensity=2.0)), 1.0, (8, 8))
    rng = np.random.default_rng(4)
    b = rng.dirichlet(np.ones(81)).reshape(1, 9, 9)
    cells = neighbour_cells((4, 4), "neighbours")
    lo = inf.lattice_outcomes(b, [table], cells, 1.2)
    pe, p, s, d = inf.lattice_posteriors(b, [table], cells, 1.2, 0.0, True)
    np.testing.assert_allclose(lo.p_found, pe, atol=1e-14)
    np.testing.assert_allclose(lo.joint, (1 - pe)[:, None] * p, atol=1e-14)
    # E[S after] - S(b) from the correlations equals the explicit posteriors' (a found source
    # leaves no uncertainty, even when several cells are found at once)
    s0 = -np.sum(b * np.log(b))
    e = rewards.expected_entropy_from(pe, p, s * math.log(2))
    np.testing.assert_allclose(lo.entropy_change, e - s0, atol=1e-12)
    assert np.all(lo.found_entropy > 0) and np.all(lo.information > 0)
    assert d is not None and np.all(d >= 0)


@pytest.mark.parametrize("dim", [2, 3])
def test_correlation_backends_agree(dim: int) -> None:
    rng = np.random.default_rng(dim)
    shape = (7, 6) if dim == 2 else (5, 4, 3)
    half = tuple(n - 1 for n in shape)
    ch = rng.random((4, *(2 * h + 1 for h in half)))
    b = rng.random(shape)
    cells = neighbour_cells(tuple(n // 2 for n in shape), "neighbours")
    ref = inf.correlate(ch, b, cells, half, backend="numpy")
    for c in range(len(cells)):
        w = tuple(slice(h - v, h - v + n) for v, h, n in zip(cells[c], half, shape, strict=True))
        np.testing.assert_allclose(
            ref[c], (ch[(slice(None), *w)] * b).sum(axis=tuple(range(1, dim + 1)))
        )
    pytest.importorskip("numba")
    np.testing.assert_allclose(inf.correlate(ch, b, cells, half, backend="numba"), ref, rtol=1e-12)
    with pytest.raises(ConfigError, match="beyond"):
        inf.correlate(ch, b, np.array([[-9] * dim]), half)


def test_ties_first_and_random() -> None:
    table = tabulate(IsotropicHitModel(), 1.0, (4, 4))
    b = np.ones((5, 5))
    b[2, 2] = 0
    b /= b.sum()
    assert _lattice_plan("infotaxis", b, [table], (2, 2)).index == 0
    picks = [
        _lattice_plan("infotaxis", b, [table], (2, 2), ties="random", rng=np.random.default_rng(s))
        for s in range(40)
    ]
    assert {p.index for p in picks} == {0, 1, 2, 3}
    again = [
        _lattice_plan("infotaxis", b, [table], (2, 2), ties="random", rng=np.random.default_rng(s))
        for s in range(40)
    ]
    assert [p.index for p in picks] == [p.index for p in again]
    # infeasible candidates (obstacle cells) are never chosen; none feasible gives None
    walls = ((1, 2), (3, 2), (2, 3))
    plan = _lattice_plan("infotaxis", b, [table], (2, 2), blocked=walls)
    assert plan.index == 2 and plan.feasible.tolist() == [False, False, True, False]
    boxed = _lattice_plan("infotaxis", b, [table], (2, 2), blocked=(*walls, (2, 1)))
    assert boxed.index is None and boxed.target is None


def test_planner_bad_input() -> None:
    table = tabulate(IsotropicHitModel(), 1.0, (2, 2))
    with pytest.raises(ConfigError) as ei:
        make_params("planner", "lattice", {"reward": {"type": "mystery"}})
    assert ei.value.field == "reward.type"
    with pytest.raises(ConfigError, match="cover"):
        _lattice_plan("infotaxis", np.ones((5, 5)) / 25, [table], (2, 2))
    with pytest.raises(ConfigError, match="moves"):
        neighbour_cells((1, 1), "knight")  # type: ignore[arg-type]
    with pytest.raises(ConfigError, match="particle beliefs"):
        inf.ParticlePlanner(make_params("planner", "particle", {"reward": {"type": "space-aware"}}))


def test_neighbour_cells_orders() -> None:
    np.testing.assert_array_equal(neighbour_cells((5, 5)), [[4, 5], [6, 5], [5, 4], [5, 6]])
    assert neighbour_cells((1, 1, 1), "lattice-stay").shape == (7, 3)
    assert neighbour_cells((1, 1, 1), "neighbours").shape == (26, 3)


class _Near(MeasurementModel):
    """A binary sensor that reads 0.9 within 1.5 m of the source, else 0.05."""

    def log_likelihood(self, z, sensor_position, hypotheses, **conditions):  # type: ignore[no-untyped-def]
        raise NotImplementedError

    def outcome_probabilities(self, s, h, **conditions):  # type: ignore[no-untyped-def]
        d = np.linalg.norm(np.atleast_2d(s)[:, None, :] - h[None], axis=2)
        return binary_outcomes(np.where(d < 1.5, 0.9, 0.05))


def _particle_plan(reward: str, belief: ParticleBelief, step: float) -> Plan:
    """The particle planner with the four lattice moves of ``step`` metres from the origin."""
    params = {"candidates": {"moves": "lattice", "step": step}, "reward": {"type": reward}}
    planner = inf.ParticlePlanner(make_params("planner", "particle", params))
    planner.reset(_ctx((-10.0, -10.0), (10.0, 10.0), (0.0, 0.0)), _Near())
    return planner.plan(belief, Pose(np.zeros(2)), np.random.default_rng(0))


def test_particle_planner_prefers_the_informative_move() -> None:
    # particles split between two spots; the binary sensor reads "near" only close to one:
    # the move towards spot A (+y) tells them apart, the one towards B (-y) stays far from B
    rng = np.random.default_rng(0)
    pts = np.concatenate([rng.normal([0, 2], 0.05, (50, 2)), rng.normal([0, -4], 0.05, (50, 2))])
    belief = ParticleBelief(pts, np.full(100, -math.log(100)))
    plan = _particle_plan("expected-entropy", belief, 1.0)  # moves -x, +x, -y, +y
    assert plan.index == 3
    assert _particle_plan("predictive-entropy", belief, 1.0).index == 3
    # a candidate on top of half the particles finds the source with probability 1/2
    found = _particle_plan("expected-entropy", ParticleBelief(pts, belief.log_weights, 0.5), 2.0)
    assert found.index == 3 and found.scores[3] < plan.scores[3]
    # greedy goes where the source is found most probably; without a found radius all tie
    assert _particle_plan("greedy", ParticleBelief(pts, belief.log_weights, 0.5), 2.0).index == 3
    assert _particle_plan("greedy", belief, 2.0).scores.tolist() == [1.0] * 4


def test_unknown_release_fast_and_explicit_agree() -> None:
    # two release hypotheses: the correlations sum over them; the explicit posteriors run over
    # the joint (release, cell) hypotheses
    model = IsotropicHitModel(IsotropicHitParams(length=1.0, intensity=1.0, n_hits=3))
    tables = [tabulate(model, 1.0, (6, 6), release=q) for q in (0.5, 2.0)]
    rng = np.random.default_rng(8)
    b = rng.dirichlet(np.ones(2 * 49)).reshape(2, 7, 7)
    cells = neighbour_cells((3, 3))
    lo = inf.lattice_outcomes(b, tables, cells, 0.5)
    pe, p, s, _ = inf.lattice_posteriors(b, tables, cells, 0.5)
    s0 = -np.sum(b * np.log(b))
    e = rewards.expected_entropy_from(pe, p, s * math.log(2))
    np.testing.assert_allclose(lo.entropy_change, e - s0, atol=1e-12)
    plan = _lattice_plan("infotaxis", b, tables, (3, 3), floor=0.0)
    assert plan.index == int(np.argmin(e))


def test_select_first_tie_is_the_first_index_of_the_best() -> None:
    """``select`` (first-index ties) against a direct reading of its rule: NaN, infinite and
    infeasible scores never win, equal scores (``-0.0 == 0.0`` too) go to the lowest index."""
    from odorloc.planning.selection import select

    rng = np.random.default_rng(4)
    for _ in range(2000):
        n = int(rng.integers(1, 9))
        s = rng.choice([-1.0, -0.0, 0.0, 0.5, 2.0, np.nan, np.inf, -np.inf], n)
        feas = rng.random(n) < 0.8 if rng.random() < 0.5 else None
        for mode in ("min", "max"):
            ok = np.isfinite(s) & (feas if feas is not None else True)
            if not ok.any():
                want = None
            else:
                v = s if mode == "min" else -s
                best = min(v[ok])
                want = next(i for i in range(n) if ok[i] and v[i] == best)
            assert select(s, mode=mode, feasible=feas) == want
