"""The public contract checkers (:mod:`odorloc.checks`) over every registered component."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from odorloc import checks
from odorloc.core import registry
from odorloc.core.errors import ConfigError
from odorloc.engine.episode import EpisodeResult
from odorloc.engine.recorder import Recording
from odorloc.scenarios import Scenario
from odorloc.scenarios.build import build_world


def _filament_movie(dim: int, path: Path) -> Path:
    """A filament movie of the contract arena in a meandering wind, so that the replayed wind
    turns from frame to frame; it lasts longer than the wind check's 2.5 s."""
    sc = checks.small_scenario({"type": "zigzag"}, dim).with_overrides(
        {"world.wind": {"type": "meander", "speed": 0.6, "vertical_std": 0.05}}
    )
    world = build_world(sc)
    rng = np.random.default_rng(3)
    world.reset(rng)
    world.record(3.0, 0.5, rng, dt=0.1).save(path)
    return path


@pytest.mark.parametrize("name", registry.names("wind"))
def test_every_wind(name: str, tmp_path: Path) -> None:
    if name != "replay":
        checks.check_wind(name)
        return
    # a replayed wind needs a movie, one per dimension
    for dim in (2, 3):
        movie = _filament_movie(dim, tmp_path / f"movie-{dim}d.npz")
        report = checks.check_wind(name, {"path": str(movie)}, dims=(dim,))
        assert report == f"wind replay: {dim}D"


@pytest.mark.parametrize("name", registry.names("plume"))
def test_every_plume(name: str) -> None:
    checks.check_plume(name)


@pytest.mark.parametrize(
    ("name", "params"),
    [(name, {}) for name in registry.names("gas_sensor")]
    + [
        # thresholds above one hit or unit: a detection that ignores the threshold is caught
        ("encounter", {"threshold": 3}),
        ("pid-count", {"ppm_per_hit": 10.0, "threshold": 2}),
        ("concentration", {"threshold": 5.0}),
    ],
)
def test_every_gas_sensor(name: str, params: dict) -> None:
    report = checks.check_sensor(name, params)
    assert report.startswith(f"gas sensor {name}: ")


@pytest.mark.parametrize(
    ("name", "params", "detections"),
    [
        ("pid-count", {"ppm_per_hit": 1000.0}, 0),  # far above the world's peak: never a hit
        ("concentration", {"threshold": 0.0}, 22),  # clean air reads 0 >= 0: always detects
    ],
)
def test_sensor_check_needs_readings_on_both_sides_of_the_threshold(
    name: str, params: dict, detections: int
) -> None:
    # with every reading on one side the threshold agreement would be checked on nothing
    with pytest.raises(checks.ContractError, match=rf"^sensor {name}: {detections} of 22 "):
        checks.check_sensor(name, params)


@pytest.mark.parametrize("name", registry.names("platform"))
def test_every_platform(name: str) -> None:
    checks.check_platform(name)


@pytest.mark.parametrize("name", registry.names("searcher"))
def test_every_searcher(name: str) -> None:
    report = checks.check_searcher(name)
    # every dimension the searcher supports, alone (or its fewest agents) and as a team of 3
    cls = registry.entry("searcher", name).build
    dims = [d for d in (2, 3) if d in getattr(cls, "dims", (2, 3))]
    counts = sorted({max(1, cls.min_agents), max(3, cls.min_agents)})
    runs = ", ".join(f"{d}D x{n}" for d in dims for n in counts)
    assert dims and report == f"searcher {name}: {runs}"


@pytest.mark.parametrize("name", registry.names("searcher"))
def test_every_searcher_rejects_unknown_parameters(name: str) -> None:
    with pytest.raises(ConfigError) as ei:
        checks.small_scenario({"type": name, "not_a_parameter": 1})
    assert ei.value.field == "searcher.not_a_parameter"


def _result(x: float) -> EpisodeResult:
    p = np.array([[[x, 0.0]]])
    rec = Recording(
        t=np.zeros(1),
        positions=p,
        gas=np.zeros((1, 1)),
        detection=np.zeros((1, 1), bool),
        wind=np.zeros_like(p),
        diagnostics={},
        beliefs=[],
        plume_t=np.zeros(0),
        plume_frames=np.zeros((0, 2, 2)),
        plume_extent=np.zeros(4),
        sources=np.zeros((1, 2)),
        declared=np.zeros((0, 2)),
        occupancy=None,
        arena_bounds=np.zeros((2, 2)),
    )
    return EpisodeResult({"search_time": 1.0}, rec)


def test_determinism_check_catches_differing_runs() -> None:
    with pytest.raises(checks.ContractError, match="trajectories differ"):
        checks.compare_runs(_result(0.0), _result(1.0), "searcher broken")
    checks.compare_runs(_result(0.0), _result(0.0), "searcher fine")


def test_small_scenario_is_a_valid_scenario() -> None:
    sc = checks.small_scenario({"type": "zigzag"}, dim=3, n_agents=2)
    assert isinstance(sc, Scenario) and len(sc.agents.starts) == 2


def test_components_by_import_path_must_belong_to_the_family() -> None:
    from odorloc.core import registry
    from odorloc.core.errors import ConfigError

    e = registry.entry("plume", "odorloc.replay.gaden:GadenPlume", field="world.plume.type")
    assert e.name == "odorloc.replay.gaden:GadenPlume"
    for family, ref, words in (
        ("searcher", "odorloc.planning.fixed_step:FixedStepInfotaxis", "not a searcher"),
        ("wind", "odorloc.searchers.uav_team:ColInfTeam", "not a wind"),
        ("searcher", ":", "package.module:Class"),
        ("searcher", ".x:Y", "cannot import"),
        ("searcher", "odorloc.nothing_here:X", "cannot import"),
    ):
        with pytest.raises(ConfigError, match=words) as ei:
            registry.entry(family, ref, field="x.type")
        assert ei.value.field == "x.type"


# ----------------------------------------------------------------------------- measurement models
#: Conditions the models' calls need (wind and windows in 3 components; cut for 2-D).
MODEL_CONDITIONS: dict[str, dict] = {
    "gaussian": {"wind": [0.5, 0.1, 0.0]},
    "pang-farrell": {"wind_window": np.tile([0.4, 0.1, 0.0], (10, 1)), "dt": 0.5},
    "vergassola": {"dt": 1.0},
}


@pytest.mark.parametrize("name", registry.names("model"))
def test_every_measurement_model(name: str) -> None:
    report = checks.check_measurement_model(name, conditions=MODEL_CONDITIONS.get(name))
    assert report == f"model {name}: 2D, 3D"


@pytest.mark.parametrize("name", registry.names("resampler"))
def test_every_resampler(name: str) -> None:
    assert checks.check_resampler(name) == f"resampler {name}: 2D, 3D"


from odorloc.inference.particles.resampling import SystematicResampler  # noqa: E402
from odorloc.models.lattice import IsotropicHitModel  # noqa: E402


class LeakyModel(IsotropicHitModel):
    """Its outcome classes lose a tenth of the probability."""

    def outcome_probabilities(self, sensor_positions, hypotheses, **conditions):
        return 0.9 * super().outcome_probabilities(sensor_positions, hypotheses, **conditions)


class NaNModel(IsotropicHitModel):
    """A hypothesis on the sensor gets a NaN log-likelihood."""

    def log_likelihood(self, z, sensor_position, hypotheses, **conditions):
        ll = super().log_likelihood(z, sensor_position, hypotheses, **conditions)
        at = np.all(np.asarray(hypotheses) == np.asarray(sensor_position), axis=1)
        return np.where(at, np.nan, ll)


class BlindResampler(SystematicResampler):
    """Ignores the weights: every particle is an equally likely ancestor."""

    def _resample(self, positions, weights, rng, n, constraint):
        return positions[rng.integers(0, len(positions), n)]


class ScribblingResampler(SystematicResampler):
    """Resamples correctly but scribbles on the caller's positions."""

    def _resample(self, positions, weights, rng, n, constraint):
        positions[0] = 0.0  # what a missing copy does to the caller's particles
        return super()._resample(positions, weights, rng, n, constraint)


@pytest.mark.parametrize(
    ("check", "ref", "problem"),
    [
        (checks.check_measurement_model, "LeakyModel", "classes sum to 1 within 1.00e-01"),
        (checks.check_measurement_model, "NaNModel", "NaN log-likelihood"),
        (checks.check_resampler, "BlindResampler", "does not move the cloud towards"),
        (checks.check_resampler, "ScribblingResampler", "inputs modified"),
    ],
)
def test_the_model_and_resampler_checkers_catch_broken_members(check, ref, problem) -> None:
    with pytest.raises(checks.ContractError, match=problem):
        check(f"test_contracts:{ref}")
