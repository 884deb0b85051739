"""Sensors: gas concentration chain, encounter counter, anemometer and pre-processing."""

from __future__ import annotations

import math

import numpy as np
import pydantic
import pytest

from odorloc.core import registry
from odorloc.core.errors import ConfigError
from odorloc.geometry.arena import Arena
from odorloc.plume.base import PlumeModel
from odorloc.plume.sources import Source
from odorloc.sensors import (
    Anemometer,
    AnemometerParams,
    ConcentrationSensor,
    ConcentrationSensorParams,
    EncounterSensor,
    EncounterSensorParams,
    GasReading,
    PreprocessorParams,
    SignalPreprocessor,
    align_delay,
    average_wind,
    delay_steps,
    moving_baseline,
    relative_concentration,
    signal_intensity,
    wind_from_polar,
)
from odorloc.sensors.preprocessing import WindAverage
from odorloc.wind import UniformWind, UniformWindParams

SRC = (2.0, 1.0)


class StubPlume(PlumeModel):
    """A fixed Gaussian bump ``level * exp(-r^2 / (2 sigma^2))`` around the source."""

    def __init__(self, dim: int = 2, level: float = 1.0, sigma: float = 0.5) -> None:
        lo, hi = (0.0,) * dim, (5.0, 3.0, 2.0)[:dim]
        arena = Arena.box(lo, hi, 0.1)
        vel = (1.0, 0.0, 0.0)[:dim]
        wind = UniformWind(UniformWindParams(velocity=vel), arena)
        super().__init__(arena, wind, [Source(position=(*SRC, 1.0)[:dim])])
        self.level = level
        self.sigma = sigma

    def _concentration(self, points: np.ndarray) -> np.ndarray:
        r2 = np.sum((points - self.source_positions[0]) ** 2, axis=1)
        return self.level * np.exp(-0.5 * r2 / self.sigma**2)

    def frame(self) -> dict[str, np.ndarray]:
        return {"level": np.array(self.level), "sigma": np.array(self.sigma)}


def _sensor(**kw: object) -> ConcentrationSensor:
    s = ConcentrationSensor(ConcentrationSensorParams(**kw))  # type: ignore[arg-type]
    s.reset(np.random.default_rng(0))
    return s


# ---------------------------------------------------------------------- concentration sensor
def test_reading_of_the_true_field() -> None:
    plume = StubPlume(level=3.0)
    s = _sensor(threshold=1.0)
    rng = np.random.default_rng(0)
    r = s.measure(plume, SRC, 0.5, rng)
    assert isinstance(r, GasReading)
    assert r.raw == pytest.approx(3.0) and r.value == pytest.approx(3.0) and r.detection
    far = s.measure(plume, (4.5, 2.5), 0.5, rng)
    expected = 3.0 * math.exp(-0.5 * (2.5**2 + 1.5**2) / 0.25)
    assert far.raw == pytest.approx(expected) and not far.detection


def test_lag_step_response_matches_exponential() -> None:
    plume = StubPlume(level=0.0)
    tau, dt = 2.0, 0.1
    s = _sensor(tau=tau, start="zero")
    rng = np.random.default_rng(0)
    plume.level = 1.0  # the step arrives at call 0
    ys = [s.measure(plume, SRC, dt, rng).value for _ in range(60)]
    t = dt * (np.arange(60) + 1)
    np.testing.assert_allclose(ys, 1.0 - np.exp(-t / tau), rtol=0, atol=1e-12)


def test_pure_delay_shifts_exactly_and_rounds_to_periods() -> None:
    rng = np.random.default_rng(3)
    x = rng.uniform(0.0, 10.0, 40)
    for delay, n in ((0.5, 5), (0.26, 3), (0.0, 0)):
        s = _sensor(delay=delay, start="steady")
        assert s.delay_steps(0.1) == n
        y = np.array([s.respond(v, 0.1, rng).value for v in x])
        np.testing.assert_array_equal(y[n:], x[: len(x) - n])
        np.testing.assert_array_equal(y[:n], x[0])  # steady start: the first value
    s = _sensor(delay=0.5, start="zero")
    y = np.array([s.respond(v, 0.1, rng).value for v in x])
    np.testing.assert_array_equal(y[:5], 0.0)
    np.testing.assert_array_equal(y[5:], x[:-5])


def test_delay_then_lag_compose() -> None:
    s = _sensor(delay=0.3, tau=1.0, start="zero")
    rng = np.random.default_rng(0)
    y = np.array([s.respond(1.0, 0.1, rng).value for _ in range(20)])
    np.testing.assert_array_equal(y[:3], 0.0)
    k = np.arange(17) + 1
    np.testing.assert_allclose(y[3:], 1.0 - np.exp(-0.1 * k / 1.0), atol=1e-12)


def test_gain_offset_saturation_and_threshold() -> None:
    rng = np.random.default_rng(0)
    s = _sensor(gain=2.0, offset=0.5, threshold=3.0)
    r = s.respond(1.0, 0.5, rng)
    assert r.value == pytest.approx(2.5) and not r.detection and r.raw == 1.0
    r = s.respond(1.25, 0.5, rng)
    assert r.value == pytest.approx(3.0) and r.detection  # value >= threshold
    sat = _sensor(max_value=10.0, threshold=5.0)
    assert sat.respond(1e6, 0.5, rng).value == 10.0
    neg = _sensor(offset=-4.0)
    assert neg.respond(1.0, 0.5, rng).value == 0.0
    pms = _sensor(threshold=200.0, binarize=True)  # PMS5003-like binarised at 200 ppm
    assert pms.respond(250.0, 0.5, rng).value == 1.0
    assert pms.respond(150.0, 0.5, rng).value == 0.0


def test_noise_statistics() -> None:
    """20000 readings at c = 5 with noise 0.5: std within 2 %, mean within 0.02."""
    s = _sensor(noise_std=0.5)
    rng = np.random.default_rng(42)
    y = np.array([s.respond(5.0, 0.5, rng).value for _ in range(20000)])
    assert y.std() == pytest.approx(0.5, rel=0.02)
    assert y.mean() == pytest.approx(5.0, abs=0.02)


def test_noise_clipped_at_zero() -> None:
    s = _sensor(noise_std=1.0)
    rng = np.random.default_rng(1)
    y = np.array([s.respond(0.0, 0.5, rng).value for _ in range(4000)])
    assert y.min() == 0.0
    assert np.mean(y == 0.0) == pytest.approx(0.5, abs=0.03)


def test_gas_sensor_deterministic_per_seed() -> None:
    plume = StubPlume()
    pts = np.column_stack([np.linspace(0.5, 4.5, 30), np.full(30, 1.2)])

    def run(seed: int) -> list[float]:
        s = _sensor(noise_std=0.2, tau=0.7, delay=0.4)
        rng = np.random.default_rng(seed)
        return [s.measure(plume, p, 0.1, rng).value for p in pts]

    assert run(5) == run(5)
    assert run(5) != run(6)


def test_gas_sensor_bad_calls() -> None:
    plume = StubPlume()
    s = _sensor()
    rng = np.random.default_rng(0)
    for dt in (0.0, -1.0, math.nan):
        with pytest.raises(ConfigError) as exc:
            s.measure(plume, SRC, dt, rng)
        assert exc.value.field == "dt"
    s.measure(plume, SRC, 0.5, rng)
    with pytest.raises(ConfigError, match="constant"):
        s.measure(plume, SRC, 0.25, rng)
    s.reset(rng)
    s.measure(plume, SRC, 0.25, rng)  # a reset allows a new period
    with pytest.raises(ConfigError) as exc:
        s.measure(plume, (1.0, 1.0, 1.0), 0.25, rng)
    assert exc.value.field == "position"


@pytest.mark.parametrize(
    ("family", "name", "field", "value"),
    [
        ("gas_sensor", "concentration", "tau", -1.0),
        ("gas_sensor", "concentration", "noise_std", math.nan),
        ("gas_sensor", "concentration", "delay", math.inf),
        ("gas_sensor", "concentration", "threshold", math.nan),
        ("gas_sensor", "concentration", "max_value", 0.0),
        ("gas_sensor", "encounter", "gain", -2.0),
        ("gas_sensor", "encounter", "threshold", 0),
        ("anemometer", "anemometer", "samples", 0),
        ("anemometer", "anemometer", "noise_std", math.nan),
    ],
)
def test_bad_params_name_the_field(family: str, name: str, field: str, value: object) -> None:
    with pytest.raises(ConfigError) as exc:
        registry.make_params(family, name, {field: value})
    assert exc.value.field == field
    with pytest.raises(ConfigError) as exc:
        registry.make_params(family, name, {"no_such_field": 1})
    assert exc.value.field == "no_such_field"


def test_registered_names_and_builders() -> None:
    assert {"concentration", "encounter"} <= set(registry.names("gas_sensor"))
    assert "anemometer" in registry.names("anemometer")
    p = registry.make_params("gas_sensor", "concentration", {"tau": 1.0, "threshold": 2.0})
    s = registry.entry("gas_sensor", "concentration").build(p)
    assert isinstance(s, ConcentrationSensor) and s.params.tau == 1.0


def test_pydantic_error_names_field_directly() -> None:
    with pytest.raises(pydantic.ValidationError, match="tau"):
        ConcentrationSensorParams(tau=-0.1)


# ---------------------------------------------------------------------- encounter counter
def test_encounter_counts_are_poisson() -> None:
    """Mean and variance of 20000 counts equal rate*dt = 1.5 within 3 % / 5 %."""
    plume = StubPlume(level=3.0)
    s = EncounterSensor(EncounterSensorParams())
    s.reset(np.random.default_rng(0))
    rng = np.random.default_rng(9)
    readings = [s.measure(plume, SRC, 0.5, rng) for _ in range(20000)]
    h = np.array([r.value for r in readings])
    assert readings[0].raw == pytest.approx(1.5)
    assert h.mean() == pytest.approx(1.5, rel=0.03)
    assert h.var() == pytest.approx(1.5, rel=0.05)
    det = np.array([r.detection for r in readings])
    np.testing.assert_array_equal(det, h > 0)
    assert det.mean() == pytest.approx(1.0 - math.exp(-1.5), abs=0.01)


def test_encounter_gain_threshold_and_zero_rate() -> None:
    plume = StubPlume(level=2.0)
    rng = np.random.default_rng(0)
    s = EncounterSensor(EncounterSensorParams(gain=0.5, threshold=2))
    assert s.expected(plume, SRC, 2.0) == pytest.approx(2.0)
    r = [s.measure(plume, SRC, 2.0, rng) for _ in range(200)]
    assert all(x.detection == (x.value >= 2) for x in r)
    plume.level = 0.0
    assert all(s.measure(plume, SRC, 1.0, rng).value == 0 for _ in range(50))


def test_encounter_deterministic_per_seed() -> None:
    plume = StubPlume(level=2.0)
    s = EncounterSensor(EncounterSensorParams())
    a = [s.measure(plume, SRC, 0.5, np.random.default_rng(4)).value for _ in range(3)]
    rng1, rng2 = np.random.default_rng(8), np.random.default_rng(8)
    assert [s.measure(plume, SRC, 0.5, rng1).value for _ in range(50)] == [
        s.measure(plume, SRC, 0.5, rng2).value for _ in range(50)
    ]
    assert len(set(a)) == 1


# ---------------------------------------------------------------------- anemometer
def _wind(dim: int = 2) -> UniformWind:
    arena = Arena.box((0.0,) * dim, (5.0, 3.0, 2.0)[:dim], 0.1)
    return UniformWind(UniformWindParams(velocity=(1.0, 0.5, 0.1)[:dim]), arena)


def test_anemometer_world_and_relative_frames() -> None:
    wind = _wind()
    vp = np.array([0.3, -0.2])
    rng = np.random.default_rng(0)
    world = Anemometer(AnemometerParams())
    rel = Anemometer(AnemometerParams(relative=True))
    np.testing.assert_allclose(world.measure(wind, (1.0, 1.0), vp, 0.5, rng), [1.0, 0.5])
    np.testing.assert_allclose(rel.measure(wind, (1.0, 1.0), vp, 0.5, rng), [0.7, 0.7])
    np.testing.assert_allclose(rel.measure(wind, (1.0, 1.0), None, 0.5, rng), [1.0, 0.5])


def test_anemometer_3d_and_bad_inputs() -> None:
    wind = _wind(3)
    rng = np.random.default_rng(0)
    a = Anemometer(AnemometerParams(relative=True))
    out = a.measure(wind, (1.0, 1.0, 1.0), (0.0, 0.0, 1.0), 0.5, rng)
    assert out.shape == (3,)
    np.testing.assert_allclose(out, [1.0, 0.5, -0.9])
    with pytest.raises(ConfigError) as exc:
        a.measure(wind, (1.0, 1.0, 1.0), (0.0, 1.0), 0.5, rng)
    assert exc.value.field == "platform_velocity"
    with pytest.raises(ConfigError) as exc:
        a.measure(wind, (1.0, 1.0, 1.0), None, -0.5, rng)
    assert exc.value.field == "dt"


def test_anemometer_noise_averaging() -> None:
    """M_f = 4 sub-readings of std 0.4 give std 0.2 per axis (20000 readings, 3 %)."""
    wind = _wind()
    a = Anemometer(AnemometerParams(noise_std=0.4, samples=4))
    rng = np.random.default_rng(17)
    r = np.array([a.measure(wind, (1.0, 1.0), (0.5, 0.5), 0.5, rng) for _ in range(20000)])
    np.testing.assert_allclose(r.std(axis=0), [0.2, 0.2], rtol=0.03)
    np.testing.assert_allclose(r.mean(axis=0), [1.0, 0.5], atol=0.01)
    assert a.effective_std == pytest.approx(0.2)
    rng1, rng2 = np.random.default_rng(3), np.random.default_rng(3)
    np.testing.assert_array_equal(
        a.measure(wind, (1.0, 1.0), None, 0.5, rng1), a.measure(wind, (1.0, 1.0), None, 0.5, rng2)
    )


# ---------------------------------------------------------------------- pre-processing
def test_wind_average_eq1() -> None:
    sp = wind_from_polar([1.0, 2.0], [0.0, math.pi / 2])
    np.testing.assert_allclose(sp, [[1.0, 0.0], [0.0, 2.0]], atol=1e-15)
    readings = np.array([[[1.0, 0.0], [3.0, 2.0]], [[0.0, 1.0], [0.0, 3.0]]])
    np.testing.assert_allclose(average_wind(readings), [[2.0, 1.0], [0.0, 2.0]])
    with pytest.raises(ConfigError):
        average_wind(np.zeros((3, 2)))


def test_delay_steps_floor_eq2() -> None:
    assert delay_steps(5.9, 0.5) == 11
    assert delay_steps(6.0, 0.5) == 12
    assert delay_steps(0.0, 0.5) == 0
    with pytest.raises(ConfigError):
        delay_steps(-1.0, 0.5)
    c = np.arange(10.0)
    np.testing.assert_array_equal(align_delay(c, 3), np.arange(3.0, 10.0))


def test_baseline_relative_and_intensity_eqs_3_to_5() -> None:
    c = np.array([2.0, 4.0, 0.0, 3.0])
    cbar = moving_baseline(c)
    np.testing.assert_allclose(cbar, [2.0, 3.0, 1.5, 2.25])
    np.testing.assert_allclose(relative_concentration(c, cbar), [0.0, 2.0, 0.0, 1.5])
    np.testing.assert_allclose(signal_intensity(c, cbar, 10.0), [0.0, 10.0, 0.0, 10.0])
    # Clean air: the floored baseline keeps s finite.
    s = signal_intensity(np.array([0.0, 0.0, 1.0]), np.zeros(3), 1.0, 1e-3)
    np.testing.assert_allclose(s, [0.0, 0.0, 1e3])


def test_online_equals_batch() -> None:
    rng = np.random.default_rng(21)
    N, M, k = 60, 4, 3
    c = rng.gamma(2.0, 1.0, N) * (rng.random(N) < 0.6)
    wind = rng.normal(1.0, 0.3, (N, M, 2))
    p = PreprocessorParams(delay=1.7, period=0.5, gain=2.0)
    assert p.delay_steps == k
    pre = SignalPreprocessor(p)
    batch = pre.process(c, wind)
    assert len(batch.index) == N - k
    np.testing.assert_allclose(batch.wind, wind.mean(axis=1)[: N - k])
    np.testing.assert_array_equal(batch.concentration, c[k:])
    online = pre.online()
    out = [online.update(c[i], wind[i]) for i in range(N)]
    assert out[:k] == [None] * k
    rows = [o for o in out if o is not None]
    assert [r.index for r in rows] == list(range(N - k))
    np.testing.assert_allclose([r.baseline for r in rows], batch.baseline, rtol=1e-12)
    np.testing.assert_allclose([r.relative for r in rows], batch.relative, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose([r.intensity for r in rows], batch.intensity, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(np.array([r.wind for r in rows]), batch.wind)
    online.reset()
    assert online.update(c[0], wind[0]) is None


def test_preprocess_realigns_delayed_sensor() -> None:
    """A sensor with a 2 s delay read at 0.5 s: pre-processing restores the true record."""
    rng = np.random.default_rng(0)
    truth = rng.uniform(0.0, 5.0, 30)
    s = _sensor(delay=2.0)
    read = np.array([s.respond(v, 0.5, rng).value for v in truth])
    out = SignalPreprocessor(PreprocessorParams(delay=2.0, period=0.5)).process(
        read, np.ones((30, 1, 2))
    )
    np.testing.assert_array_equal(out.concentration, truth[: 30 - 4])


def test_preprocess_length_mismatch() -> None:
    with pytest.raises(ConfigError) as exc:
        SignalPreprocessor().process(np.zeros(5), np.zeros((4, 2, 2)))
    assert exc.value.field == "wind_readings"


def test_signal_intensity_by_hand() -> None:
    # eq. (3) with w = 1/2: c_bar = 10, 11, 11, 15.5; eq. (5): s = K (c / c_bar_prev - 1)
    # when c >= c_bar_prev; eq. (2): with a one-period delay the reading at i belongs to i - 1
    from odorloc.sensors.preprocessing import PreprocessorParams, preprocess

    c = np.array([10.0, 12.0, 11.0, 20.0])
    winds = np.zeros((4, 1, 2))
    s = preprocess(c, winds, PreprocessorParams(gain=2.0, period=0.5)).intensity
    np.testing.assert_allclose(s, [0.0, 0.4, 0.0, 2.0 * (20.0 / 11.0 - 1.0)])
    d = preprocess(c, winds, PreprocessorParams(gain=2.0, period=0.5, delay=0.5))
    np.testing.assert_array_equal(d.index, [0, 1, 2])
    np.testing.assert_allclose(d.concentration, [12.0, 11.0, 20.0])


def test_preprocess_refuses_missing_readings_instead_of_poisoning_the_baseline() -> None:
    c = np.array([50.0, 52.0, math.nan, 55.0, 60.0, 58.0])
    winds = np.ones((6, 2, 2))
    pre = SignalPreprocessor(PreprocessorParams(period=0.5))
    with pytest.raises(ConfigError) as exc:
        pre.process(c, winds)
    assert exc.value.field == "concentration"
    gappy = winds.copy()
    gappy[1, 0, 0] = math.nan
    with pytest.raises(ConfigError) as exc:
        pre.process(np.ones(6), gappy)
    assert exc.value.field == "wind_readings"
    online = pre.online()
    online.update(c[0], winds[0])
    with pytest.raises(ConfigError) as exc:
        online.update(c[2], winds[2])
    assert exc.value.field == "concentration"
    with pytest.raises(ConfigError) as exc:
        online.update(c[1], gappy[1])
    assert exc.value.field == "wind_readings"
    # a refused period leaves the state as it was: the stream continues as if it never came
    rest = [online.update(x, winds[0]) for x in c[[1, 3, 4]]]
    batch = pre.process(c[[0, 1, 3, 4]], winds[:4])
    np.testing.assert_allclose([r.intensity for r in rest], batch.intensity[1:], rtol=1e-12)


def test_pid_hits_refuse_non_finite_readings_and_bad_scale() -> None:
    from odorloc.sensors import hits_from_concentration

    np.testing.assert_array_equal(hits_from_concentration([-5.0, 250.0], 100.0), [0, 2])
    for bad in ([math.nan], [250.0, math.inf]):
        with pytest.raises(ConfigError) as exc:
            hits_from_concentration(bad, 100.0)
        assert exc.value.field == "concentration"
    for scale in (0.0, -100.0, math.nan):
        with pytest.raises(ConfigError) as exc:
            hits_from_concentration([250.0], scale)
        assert exc.value.field == "ppm_per_hit"


# ---------------------------------------------------------------------- wind average
def test_wind_average() -> None:
    w = WindAverage(2)
    w.add([1.0, 0.0])
    np.testing.assert_allclose(w.add([3.0, 2.0]), [2.0, 1.0])
    np.testing.assert_allclose(w.add([1.0, 0.0]), [2.0, 1.0])  # the oldest dropped
    np.testing.assert_allclose(w.upwind(0.0), -np.array([2.0, 1.0]) / math.sqrt(5.0))


def test_wind_average_refuses_a_non_finite_reading() -> None:
    w = WindAverage(3)
    w.add([1.0, 0.0])
    with pytest.raises(ConfigError, match="wind"):
        w.add([math.nan, 0.0])
    # the refused reading left the average alone
    np.testing.assert_allclose(w.upwind(0.3), [-1.0, 0.0])
