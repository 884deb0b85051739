"""The single-agent estimator family: the contract over every member, and the parts of the
particle filter (readings, initialisation, resampling policies, stopping rules)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from odorloc import checks
from odorloc.core import registry
from odorloc.core.errors import ConfigError
from odorloc.core.types import Observation
from odorloc.inference.particles.estimator import ParticleFilterEstimator
from odorloc.inference.readings import OutcomeClassReading, WindWindowReading
from odorloc.models.pang_farrell import PangFarrellModel
from odorloc.models.vergassola import VergassolaModel

#: Settings that keep a member's contract run cheap (the contract does not depend on them).
ESTIMATOR_PARAMS: dict[str, dict] = {"ste-pf": {"n_particles": 500}}


@pytest.mark.parametrize("name", registry.names("estimator"))
def test_every_estimator(name: str) -> None:
    report = checks.check_estimator(name, ESTIMATOR_PARAMS.get(name))
    cls = registry.entry("estimator", name).build
    for d in cls.dims:
        assert f"{d}D (" in report


class Flat(ParticleFilterEstimator):
    """A broken member: its estimate is ``(d,)``, not ``(k, d)``."""

    def estimate(self) -> np.ndarray:
        return np.zeros(self.ctx.dim)


class Unseeded(ParticleFilterEstimator):
    """A broken member: it ignores the stream it is given."""

    def reset(self, ctx, model, rng):  # type: ignore[no-untyped-def]
        super().reset(ctx, model, np.random.default_rng())

    def use_stream(self, rng: np.random.Generator) -> None:
        return None


@pytest.mark.parametrize(("cls", "what"), [(Flat, "estimate shape"), (Unseeded, "per seed")])
def test_the_estimator_check_catches_a_broken_member(cls: type, what: str) -> None:
    with pytest.raises(checks.ContractError, match=what):
        checks.check_estimator(f"{__name__}:{cls.__name__}", dims=(2,))


def _obs(k: int, wind: tuple[float, float], det: bool = False, gas: float = 0.0) -> Observation:
    return Observation(0, 0.5 * k, np.array([5.0, 3.0]), 0.0, gas, det, np.array(wind))


def test_wind_window_reading_pads_and_shifts() -> None:
    ctx, _ = checks.observation_stream(2)
    r = WindWindowReading(WindWindowReading.Params(window=3, wind_var_window=1.0))
    r.reset(ctx)
    c0 = r.update(_obs(0, (1.0, 0.0)))
    # no record before the first reading: the window is the reading itself, padded
    np.testing.assert_array_equal(c0["wind_window"], [[1.0, 0.0]] * 3)
    assert c0["dt"] == ctx.dt and c0["wind_var"].tolist() == [0.0, 0.0]
    c1 = r.update(_obs(1, (3.0, 0.0)))
    np.testing.assert_array_equal(c1["wind_window"], [[1.0, 0.0]] * 3)
    # the variance of the last 1 s (two readings at 0.5 s, this one included)
    np.testing.assert_allclose(c1["wind_var"], [1.0, 0.0])
    # the next reading's window holds this one, oldest first
    np.testing.assert_array_equal(r.next_conditions()["wind_window"], [[1, 0], [1, 0], [3, 0]])


def test_outcome_class_reading() -> None:
    ctx, _ = checks.observation_stream(2)
    r = OutcomeClassReading(OutcomeClassReading.Params(wind_average=2, exposure=2.0))
    r.reset(ctx)
    c = r.update(_obs(0, (0.0, 0.0)))
    assert "direction" not in c and c["dt"] == 2.0 and c["n_classes"] == 2  # calm; detections
    c = r.update(_obs(1, (2.0, 0.0)))
    np.testing.assert_allclose(c["wind"], [1.0, 0.0])
    np.testing.assert_allclose(c["direction"], [1.0, 0.0])
    assert r.next_conditions() is c
    hits = OutcomeClassReading(OutcomeClassReading.Params(reading="hits"))
    hits.reset(ctx)
    assert hits.class_of(_obs(0, (1.0, 0.0), gas=7.0), 4) == 3  # capped at the last class
    with pytest.raises(ConfigError, match="reading"):
        hits.class_of(_obs(0, (1.0, 0.0), gas=math.nan), 4)


def _pf(**values: object) -> ParticleFilterEstimator:
    return ParticleFilterEstimator(registry.make_params("estimator", "particle-filter", values))


def test_back_tracking_waits_for_a_detection() -> None:
    ctx, stream = checks.observation_stream(2)
    est = _pf()
    est.reset(ctx, PangFarrellModel(), np.random.default_rng(0))
    assert est.belief() is None and est.estimate().shape == (0, 2)
    first = next(k for k, o in enumerate(stream) if o.detection)
    for o in stream[:first]:
        est.update(o)
    assert est.belief() is None and est.initial_belief() is None
    est.update(stream[first])
    b = est.belief()
    assert b is not None and b.positions.shape == (1000, 2)
    assert est.initial_belief() is not None and est.diagnostics()["n_particles"] == 1000.0
    # the cloud lies upwind (-x) of the detection, as the recorded wind blew from there
    assert b.mean[0] < stream[first].position[0]


def test_back_tracking_needs_its_model_and_reading() -> None:
    ctx, stream = checks.observation_stream(2)
    with pytest.raises(ConfigError, match="pang-farrell"):
        _pf().reset(ctx, VergassolaModel(), np.random.default_rng(0))
    est = _pf(reading={"type": "outcome-class"})
    est.reset(ctx, PangFarrellModel(), np.random.default_rng(0))
    with pytest.raises(ConfigError, match="wind-window"):
        for o in stream:
            est.update(o)
    with pytest.raises(ConfigError, match="model"):
        _pf().reset(ctx, None, np.random.default_rng(0))


def test_found_radius_rules_out_the_agents_surroundings() -> None:
    """Particles within the found radius of the agent get no weight (the search would have
    ended there); ``half-step`` is half a control period's travel at the speed limit."""
    ctx, _ = checks.observation_stream(2)
    spec = {
        "n_particles": 400,
        "reading": {"type": "outcome-class"},
        "init": {"type": "uniform", "region": [[3.0, 2.0], [7.0, 4.0]]},
        "stopping": {"type": "never"},
        "resampling": {"threshold": 0.0},
        "found_radius": 1.0,
    }
    est = _pf(**spec)
    est.reset(ctx, VergassolaModel(), np.random.default_rng(0))
    est.update(_obs(0, (0.6, 0.0)))  # the agent at (5, 3)
    b = est.belief()
    assert b is not None and b.found_radius == 1.0
    near = np.linalg.norm(b.positions - [5.0, 3.0], axis=1) <= 1.0
    assert near.any() and not near.all()
    assert np.all(b.weights[near] == 0.0) and np.all(b.weights[~near] > 0.0)
    assert est.final_metrics() == {"resamples": 0.0, "redraws": 0.0}
    half = _pf(**{**spec, "found_radius": "half-step"})
    half.reset(ctx, VergassolaModel(), np.random.default_rng(0))
    b = half.belief()
    assert b is not None and b.found_radius == pytest.approx(0.5 * ctx.max_speed * ctx.dt)


def test_grid_tables_made_in_calm_air_are_remade_once_the_wind_blows() -> None:
    """The model is tabulated at the first reading's wind, again as soon as a wind blows after
    calm air (calm tables have no direction), and kept through calm spells."""
    ctx, _ = checks.observation_stream(2)
    params = {"reading": {"wind_average": 1}, "cell_size": 0.5}
    est = registry.ComponentRef(type="grid-filter", **params).build("estimator")
    est.reset(ctx, VergassolaModel(), np.random.default_rng(0))
    assert est.conditions() == {}
    winds = []
    for k, w in enumerate(((0.0, 0.0), (1.0, 0.0), (0.0, 0.0))):
        est.update(_obs(k, w))
        winds.append(est.conditions()["wind"].tolist())
    assert winds == [[0.0, 0.0], [1.0, 0.0], [1.0, 0.0]]
    np.testing.assert_allclose(est.conditions()["direction"], [1.0, 0.0])


def test_stopping_rules_and_policies_are_parts() -> None:
    ctx, stream = checks.observation_stream(2)
    never = _pf(stopping={"type": "never"}, resampling={"type": "every-step"})
    never.reset(ctx, PangFarrellModel(), np.random.default_rng(1))
    for o in stream:
        never.update(o)
        assert not never.converged()
    updates = sum(1 for k, o in enumerate(stream) if any(s.detection for s in stream[: k + 1]))
    assert never.n_resamples == updates  # resampled after every update
    assert "spread" not in never.diagnostics()
    dual = _pf(stopping={"type": "dual-convergence", "r_conv": 1e6, "r_err": 1e6, "history": 3})
    dual.reset(ctx, PangFarrellModel(), np.random.default_rng(1))
    for o in stream:
        dual.update(o)
    assert dual.converged() and "spread" in dual.diagnostics()
    with pytest.raises(ConfigError) as ei:
        registry.make_params("estimator", "particle-filter", {"resampling": {"threshold": 2.0}})
    assert ei.value.field == "resampling.threshold"


def test_a_handed_over_stream_is_drawn_from() -> None:
    """Resampling after :meth:`use_stream` draws from the handed-over stream: the same
    observations and streams give the same particles, another stream other particles."""
    ctx, stream = checks.observation_stream(2)

    def run(seed: int) -> np.ndarray:
        est = _pf()
        est.reset(ctx, PangFarrellModel(), np.random.default_rng(0))
        act = np.random.default_rng(seed)
        for o in stream:
            est.use_stream(act)
            est.update(o)
        b = est.belief()
        assert b is not None
        return b.positions

    np.testing.assert_array_equal(run(1), run(1))
    assert not np.array_equal(run(1), run(2))
