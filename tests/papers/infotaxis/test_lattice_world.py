"""The lattice problem of infotaxis as a world: OTTO's episode start, the lattice walker, the
stuck end rule, the built-in scenarios and the statistics of our infotaxis on them."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pytest
import yaml

from odorloc.core.errors import ConfigError
from odorloc.core.params import Params
from odorloc.core.seeds import episode_seeds
from odorloc.core.types import Action, Command, Observation
from odorloc.engine.episode import Episode, run_episode
from odorloc.geometry.arena import Arena
from odorloc.models.lattice import initial_belief, initial_hit_probabilities, isotropic_mean_hits
from odorloc.models.poisson import censored_poisson
from odorloc.papers.infotaxis.lattice import lattice_problem, lattice_scenario
from odorloc.papers.infotaxis.reference import OTTO
from odorloc.platforms.lattice import LatticeWalker, LatticeWalkerParams
from odorloc.plume.lattice import LatticeIsotropicPlume, LatticePlumeParams
from odorloc.plume.sources import Source
from odorloc.scenarios import Scenario, builtin_path, get_scenario
from odorloc.searchers.base import Searcher
from odorloc.sensors.encounter import EncounterSensor, EncounterSensorParams
from odorloc.wind.uniform import UniformWind, UniformWindParams


def _plume(n: int = 19, start: str = "initial-hit", length: float = 1.0) -> LatticeIsotropicPlume:
    arena = Arena.box((0.0, 0.0), (float(n), float(n)), 1.0)
    wind = UniformWind(UniformWindParams(velocity=(0.0, 0.0)), arena)
    src = [Source(position=(n / 2, n / 2), rate=1.0)]
    return LatticeIsotropicPlume(LatticePlumeParams(length=length, start=start), arena, wind, src)


def test_first_hit_and_source_follow_otto_laws() -> None:
    plume = _plume()
    rng = np.random.default_rng(5)
    h0, cells = [], []
    for _ in range(3000):
        plume.reset(rng)
        h0.append(plume.initial_hit)
        cells.append(tuple(int(v) for v in np.floor(plume.source_positions[0])))
    ph = initial_hit_probabilities(1.0, 1.0, 1.0, 2, 3)
    freq = np.bincount(h0, minlength=3) / len(h0)
    # P(h0 = 1) = 0.849: binomial standard error 0.0065 at 3000 draws, 4 sigma
    assert abs(freq[1] - ph[1]) < 0.026
    assert freq[0] == 0.0
    # given h0 = 1 the source follows b0: the four neighbours of the start hold 4 x 0.0636
    ones = [c for c, h in zip(cells, h0, strict=True) if h == 1]
    near = np.mean([abs(c[0] - 9) + abs(c[1] - 9) == 1 for c in ones])
    assert abs(near - 4 * 0.0636231026563) < 4 * np.sqrt(0.25 * 0.75 / len(ones))
    assert all(c != (9, 9) for c in cells)


def test_initial_belief_matches_the_drawn_law() -> None:
    n = 19
    c = np.stack(np.meshgrid(np.arange(n) + 0.5, np.arange(n) + 0.5, indexing="ij"), -1)
    d = np.linalg.norm(c - 9.5, axis=-1)
    like = censored_poisson(isotropic_mean_hits(d, 1.0, 1.0, 1.0, 2), 3)[..., 1]
    b0 = initial_belief(like, (9, 9))
    assert b0[8, 9] == pytest.approx(0.0636231026563, abs=1e-11)


def test_encounter_sensor_reports_the_first_hit_once() -> None:
    plume = _plume()
    rng = np.random.default_rng(1)
    plume.reset(rng)
    s = EncounterSensor(EncounterSensorParams())
    s.reset(rng)
    start = np.array([9.5, 9.5])
    # the episode announces the start; the first reading is then the plume's initial hit
    s.start(plume, start)
    first = s.measure(plume, start, 1.0, rng)
    assert first.value == plume.initial_hit and first.detection
    # later readings are Poisson: their mean is the plume's mean hits
    vals = [s.measure(plume, start + np.array([1.0, 0.0]), 1.0, rng).value for _ in range(4000)]
    mu = plume.encounter_rate(start + np.array([1.0, 0.0]))[0]
    assert abs(np.mean(vals) - mu) < 4 * np.sqrt(mu / 4000)
    # a reset forgets a pending initial hit: where the rate is zero the next count is zero
    s.start(plume, start)
    s.reset(rng)
    assert s.respond(0.0, 1.0, rng).value == 0.0
    s.start(plume, start)  # (without the reset, the pending hit would be that count)
    assert s.respond(0.0, 1.0, rng).value == plume.initial_hit
    # an agent away from the origin has none
    assert plume.initial_hits(start + np.array([3.0, 0.0])) is None
    fixed = _plume(start="fixed")
    fixed.reset(rng)
    assert fixed.initial_hit is None and fixed.initial_hits(start) is None


def test_lattice_plume_bad_input() -> None:
    with pytest.raises(ConfigError, match="length"):
        _plume(length=0.5)
    arena = Arena.box((0.0, 0.0), (5.0, 5.0), 1.0)
    wind = UniformWind(UniformWindParams(velocity=(0.0, 0.0)), arena)
    two = [Source(position=(1.5, 1.5)), Source(position=(3.5, 3.5))]
    with pytest.raises(ConfigError, match="initial-hit"):
        LatticeIsotropicPlume(LatticePlumeParams(start="initial-hit"), arena, wind, two)


def test_lattice_walker_moves_one_cell_per_step() -> None:
    arena = Arena.box((0.0, 0.0), (5.0, 5.0), 1.0).with_boxes([((3.0, 2.0), (4.0, 3.0))])
    w = LatticeWalker()
    w.reset(np.array([2.5, 2.5]))
    w.apply(Command.move([1.0, 0.0]), 1.0, arena)  # into the obstacle cell (3, 2): impossible
    np.testing.assert_allclose(w.position, [2.5, 2.5])
    assert w.blocked and w.ready
    w.apply(Command.move([0.0, 1.0]), 1.0, arena)
    np.testing.assert_allclose(w.position, [2.5, 3.5])
    w.apply(Command.move([0.0, 1.0]), 1.0, arena)
    w.apply(Command.move([0.0, 1.0]), 1.0, arena)  # beyond the wall: stays
    np.testing.assert_allclose(w.position, [2.5, 4.5])
    # a waypoint is walked one axis move per step, the largest offset first
    w.apply(Command.waypoint([0.5, 2.5]), 1.0, arena)
    np.testing.assert_allclose(w.position, [1.5, 4.5])
    assert not w.ready
    for _ in range(3):
        w.apply(None, 1.0, arena)
    np.testing.assert_allclose(w.position, [0.5, 2.5])
    assert w.ready and w.path_length == pytest.approx(6.0)
    # half-period calls: one move every other call
    w2 = LatticeWalker(LatticeWalkerParams(step_time=1.0))
    w2.reset(np.array([0.5, 0.5]))
    w2.apply(Command.velocity([0.0, 2.0]), 0.5, arena)
    np.testing.assert_allclose(w2.position, [0.5, 0.5])
    w2.apply(None, 0.5, arena)
    np.testing.assert_allclose(w2.position, [0.5, 1.5])
    assert w2.speed_limit == 1.0


class BackAndForthParams(Params):
    """No parameters."""


class BackAndForth(Searcher):
    """+x, -x, +x, ... for ever."""

    max_agents = 1
    Params = BackAndForthParams

    def act(self, observations: Sequence[Observation], rng: np.random.Generator) -> Action:
        self.k = getattr(self, "k", 0) + 1
        return Action([Command.move([1.0 if self.k % 2 else -1.0, 0.0])])


def _stuck_scenario(limit: int | None, time: float = 100.0) -> Scenario:
    d = lattice_scenario(2, 1.0, 1.0)
    d["searcher"] = {"type": f"{__name__}:BackAndForth"}
    d["task"]["stuck_limit"] = limit
    d["limits"]["time"] = time
    # the source far from the back-and-forth pair
    d["world"]["plume"]["start"] = "fixed"
    d["world"]["sources"] = [{"position": [0.5, 0.5], "rate": 1.0}]
    return Scenario.from_dict(d)


def test_stuck_rule_ends_the_episode() -> None:
    res = run_episode(_stuck_scenario(8), 1, 2, record=False)
    # the counter grows from the second move on; it exceeds 8 at the tenth move
    assert res.metrics["termination"] == "stuck"
    assert res.metrics["steps"] == 10
    assert not res.metrics["success"]
    assert run_episode(_stuck_scenario(None, 30.0), 1, 2).metrics["termination"] == "time_limit"
    # the time limit wins when both end the same step
    assert run_episode(_stuck_scenario(8, 10.0), 1, 2).metrics["termination"] == "time_limit"
    with pytest.raises(ConfigError, match="stuck_limit"):
        d = lattice_scenario(2, 1.0, 1.0)
        d["task"]["stuck_limit"] = -1
        Scenario.from_dict(d)


@pytest.mark.parametrize(
    "name, args",
    [
        ("lattice-isotropic-2d", (2, 1.0, 1.0)),
        ("lattice-isotropic-2d-l2", (2, 2.0, 2.0)),
        ("lattice-isotropic-3d", (3, 1.0, 1.0)),
    ],
)
def test_builtin_lattice_scenarios(name: str, args: tuple) -> None:
    data = yaml.safe_load(builtin_path(name).read_text())
    assert data == lattice_scenario(*args, name=name)
    sc = get_scenario(name)
    pr = lattice_problem(*args)
    assert sc.limits.time == pr["step_cap"]
    assert sc.world.arena.upper == (float(pr["grid"]),) * args[0]
    a = run_episode(sc, *episode_seeds(0, name, 3), record=False)
    b = run_episode(sc, *episode_seeds(0, name, 3), record=False)
    # infotaxis misses the source in about 2 of 10 000 of these episodes: this one it reaches
    assert a.metrics["steps"] == b.metrics["steps"] and a.metrics["termination"] == "reached"


def test_lattice_problem_names_the_bad_parameter() -> None:
    inf = float("inf")
    for args, field in [
        ((2.0, 1.0, 1.0), "dim"),
        ((4, 1.0, 1.0), "dim"),
        ((2, inf, 1.0), "length"),
        ((2, float("nan"), 1.0), "length"),
        ((2, 1.0, inf), "intensity"),
        ((2, 1.0, 0.0), "intensity"),
    ]:
        with pytest.raises(ConfigError, match=field):
            lattice_scenario(*args)


def test_episode_starts_from_the_first_hit() -> None:
    sc = get_scenario("lattice-isotropic-2d")
    ep = Episode(sc, record=False)
    obs = ep.reset(*episode_seeds(0, "lattice-isotropic-2d", 0))
    plume = ep.world.plume
    assert isinstance(plume, LatticeIsotropicPlume)
    assert obs[0].gas == plume.initial_hit >= 1
    np.testing.assert_allclose(obs[0].position, [9.5, 9.5])
    assert not np.allclose(ep.sources[0], [9.5, 9.5])


def test_infotaxis_mean_steps_agree_with_otto() -> None:
    """400 episodes on the N = 19 problem: the mean moves of the found episodes lie within four
    combined standard errors of OTTO's (std 17.8, so about 0.9 + 0.14)."""
    sc = get_scenario("lattice-isotropic-2d")
    steps = []
    for ep in range(400):
        r = run_episode(sc, *episode_seeds(77, "lattice-isotropic-2d", ep), record=False)
        if r.metrics["success"]:
            steps.append(r.metrics["steps"])
    ref = OTTO[("2d-l1-i1", "infotaxis")]
    se = np.hypot(np.std(steps, ddof=1) / np.sqrt(len(steps)), ref["sem"])
    assert abs(np.mean(steps) - ref["mean"]) < 4 * se
    assert len(steps) >= 396


def test_unknown_release_is_learnt() -> None:
    """Readings drawn with intensity 1 around a known source: the release posterior over
    (0.5, 1, 2) concentrates on 1; a searcher with an unknown release runs its episodes."""
    from odorloc.geometry.grid import CellGrid
    from odorloc.inference.grid_filter import GridFilter
    from odorloc.models.lattice import IsotropicHitModel, IsotropicHitParams

    model = IsotropicHitModel(IsotropicHitParams(length=1.0, intensity=1.0, n_hits=3))
    f = GridFilter(CellGrid((0.0, 0.0), 1.0, (9, 9)), releases=(0.5, 1.0, 2.0))
    rng = np.random.default_rng(2)
    src = np.array([[4.5, 4.5]])
    for _ in range(400):
        s = np.floor(rng.random(2) * 9) + 0.5
        if np.allclose(s, src[0]):
            continue
        q = model.outcome_probabilities(s[None], src)[0, :, 0]
        f.observe(model, int(rng.choice(3, p=q)), s)
    assert f.release_prob[1] > 0.9
    assert np.unravel_index(int(np.argmax(f.prob)), f.shape) == (4, 4)
    sc = get_scenario("lattice-isotropic-2d")
    spec = {
        "type": "infotaxis",
        "model": {"type": "lattice-isotropic", **model.params.model_dump()},
        "estimator": {"releases": [0.5, 1.0, 2.0]},
    }
    sc = sc.with_overrides({"searcher": spec})
    for ep in range(5):
        r = run_episode(sc, *episode_seeds(3, "release", ep), record=False)
        assert r.metrics["termination"] == "reached"


def test_a_source_too_strong_for_the_automatic_hit_classes_names_n_hits() -> None:
    n = 19
    arena = Arena.box((0.0, 0.0), (float(n), float(n)), 1.0)
    wind = UniformWind(UniformWindParams(velocity=(0.0, 0.0)), arena)
    src = [Source(position=(n / 2, n / 2), rate=1e6)]
    # refused when the plume is made (the scenario is checked), not at the first reset
    with pytest.raises(ConfigError) as ei:
        LatticeIsotropicPlume(LatticePlumeParams(start="initial-hit"), arena, wind, src)
    assert ei.value.field == "world.plume.n_hits" and "set n_hits" in ei.value.problem
