"""Reading the plume once for every agent gives the readings of one sensor after another, and the
buffered Eulerian substeps give the straightforward ones bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

from odorloc import checks
from odorloc.engine.episode import Episode, prepare_world
from odorloc.geometry.arena import Arena
from odorloc.plume.eulerian import EulerianParams, EulerianPlume, _sl
from odorloc.plume.sources import Source
from odorloc.scenarios import Scenario
from odorloc.sensors.anemometer import Anemometer, AnemometerParams
from odorloc.sensors.encounter import EncounterSensor, EncounterSensorParams
from odorloc.sensors.gas import ConcentrationSensor, ConcentrationSensorParams
from odorloc.wind.uniform import UniformWind, UniformWindParams


@pytest.mark.parametrize("plume", ["eulerian", "vergassola", "gaussian"])
def test_sample_then_respond_equals_measure_one_by_one(plume) -> None:
    sc = checks.small_scenario({"type": "passive"}, 2, 5, 20.0, plume=plume)
    world, rng_w, _ = prepare_world(sc, 11)
    rng = np.random.default_rng(0)
    if plume == "vergassola":
        make = lambda: EncounterSensor(EncounterSensorParams(gain=2.0))  # noqa: E731
    else:
        make = lambda: ConcentrationSensor(  # noqa: E731
            ConcentrationSensorParams(delay=1.0, tau=0.7, noise_std=0.05, threshold=0.1)
        )
    one, batch = [make() for _ in range(5)], [make() for _ in range(5)]
    an1 = [Anemometer(AnemometerParams(noise_std=0.1)) for _ in range(5)]
    an2 = [Anemometer(AnemometerParams(noise_std=0.1)) for _ in range(5)]
    ra, rb = np.random.default_rng(3), np.random.default_rng(3)
    for _ in range(8):
        pos = np.column_stack([rng.uniform(0, 10, 5), rng.uniform(0, 6, 5)])
        vel = rng.normal(0, 0.2, (5, 2))
        a = []
        for k in range(5):
            a.append(one[k].measure(world.plume, pos[k], 0.5, ra))
            a.append(an1[k].measure(world.wind, pos[k], vel[k], 0.5, ra))
        truth = batch[0].sample(world.plume, pos)
        air = world.wind.velocity(pos)
        b = []
        for k in range(5):
            b.append(batch[k].respond(float(truth[k]), 0.5, rb))
            b.append(an2[k].respond(air[k], vel[k], 0.5, rb))
        for x, y in zip(a, b, strict=True):
            if isinstance(x, np.ndarray):
                assert np.array_equal(x, y)
            else:
                assert x == y
        for _ in range(5):
            world.step(0.1, rng_w)


def test_episode_observations_are_the_sensors_readings() -> None:
    sc = checks.small_scenario({"type": "passive"}, 2, 3, 5.0, plume="eulerian")
    data = sc.to_dict()
    data["sensors"]["gas"] = {"type": "concentration", "threshold": 0.5, "noise_std": 0.1}
    data["sensors"]["anemometer"] = {"type": "anemometer", "noise_std": 0.2}
    ep = Episode(Scenario.from_dict(data), record=False)
    obs = ep.reset(4, 5)
    # the same readings, measured one sensor after another from the episode's sensor stream
    world, _, rng_sense = prepare_world(Scenario.from_dict(data), 4)
    gas = [ConcentrationSensor(ConcentrationSensorParams(threshold=0.5, noise_std=0.1))]
    an = Anemometer(AnemometerParams(noise_std=0.2))
    for o, s in zip(obs, gas * 3, strict=True):
        s.reset()
        r = s.measure(world.plume, o.position, 0.5, rng_sense)
        w = an.measure(world.wind, o.position, np.zeros(2), 0.5, rng_sense)
        assert o.gas == r.value and np.array_equal(o.wind, w)


def _reference_faces(p: EulerianPlume) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Per axis, the faces mass may cross (``open``: neither neighbour cell solid and, with a
    closed boundary, not on the domain's edge) and the interior faces (diffusion never leaves
    the domain), as 0/1 arrays over the faces."""
    d = p.dim
    opened, interior = [], []
    for a in range(d):
        pad = np.pad(p.solid, [(1, 1) if b == a else (0, 0) for b in range(d)])
        blocked = pad[_sl(d, a, slice(None, -1))] | pad[_sl(d, a, slice(1, None))]
        inner = np.zeros(blocked.shape, bool)
        inner[_sl(d, a, slice(1, -1))] = True
        if p.params.boundary == "closed":
            blocked |= ~inner
        opened.append((~blocked).astype(float))
        interior.append(inner.astype(float))
    return opened, interior


def _reference_advance(p: EulerianPlume, dt: float) -> np.ndarray:
    """The substep loop written out plainly (padding and temporaries every substep)."""
    opened, interior = _reference_faces(p)
    cells = tuple(p.grid.index(p.source_positions).T)
    faces = p.face_velocities()
    n = max(1, int(np.ceil(dt / p.max_substep(faces) - 1e-9)))
    ds = dt / n
    d, h, D = p.dim, p.h, p.params.D
    c = p.c
    for k in range(n):
        div = np.zeros(p.shape)
        for a in range(d):
            u = faces[a]
            cp = np.pad(c, [(1, 1) if b == a else (0, 0) for b in range(d)])
            cl = cp[_sl(d, a, slice(None, -1))]
            cr = cp[_sl(d, a, slice(1, None))]
            flux = np.maximum(u, 0.0) * cl + np.minimum(u, 0.0) * cr
            if D > 0:
                flux -= (D / h) * (cr - cl) * interior[a]
            flux *= opened[a]
            div += flux[_sl(d, a, slice(1, None))] - flux[_sl(d, a, slice(None, -1))]
        c = c - (ds / h) * div
        tk = p.t + (k + 0.5) * ds
        for s, idx in zip(p.sources, zip(*cells, strict=True), strict=True):
            c[idx] += s.rate_at(tk) * ds / p.cell_volume
    return c


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("boundary", ["open", "closed"])
def test_eulerian_substeps_match_the_plain_loop_bit_for_bit(dim, boundary) -> None:
    lo, hi = ((0.0, 0.0), (6.0, 4.0)) if dim == 2 else ((0.0, 0.0, 0.0), (4.0, 3.0, 2.0))
    arena = Arena.box(lo, hi, 0.25)
    box = ((2.0, 1.0), (2.5, 2.0)) if dim == 2 else ((2.0, 1.0, 0.0), (2.5, 2.0, 1.0))
    arena = arena.with_boxes([box])
    vel = (1.2, -0.4) if dim == 2 else (1.2, -0.4, 0.1)
    src = (0.6, 2.0) if dim == 2 else (0.6, 1.5, 1.2)
    wind = UniformWind(UniformWindParams(velocity=vel), arena)
    plume = EulerianPlume(
        EulerianParams(D=0.05, boundary=boundary),
        arena,
        wind,
        [Source(position=src, rate=3.0, modulation={"kind": "sine", "period": 2.0})],
    )
    rng = np.random.default_rng(0)
    wind.reset(rng)
    plume.reset(rng)
    for _ in range(6):
        want = _reference_advance(plume, 0.4)
        wind.step(0.4, rng)
        plume.step(0.4, rng)  # the plume steps with the wind of this step, as the reference
        assert np.array_equal(plume.c, want)
    assert plume.c.max() > 0


def _rate_plume(velocity, sources, modulation=None):
    from odorloc.plume.vergassola import VergassolaParams, VergassolaPlume

    arena = Arena.box((0.0, 0.0, 0.0), (100.0, 60.0, 30.0), 2.0)
    wind = UniformWind(UniformWindParams(velocity=velocity), arena)
    src = [
        Source(position=p, rate=5.0, **({"modulation": modulation} if modulation else {}))
        for p in sources
    ]
    return VergassolaPlume(VergassolaParams(V=None), arena, wind, src)


@pytest.mark.parametrize("velocity", [(0.0, -1.0, 0.0), (0.3, -0.8, 0.1)])
@pytest.mark.parametrize("n_sources", [1, 3])
def test_rate_at_a_few_points_equals_the_array_path(velocity, n_sources) -> None:
    """The per-point Python path (up to 8 sensors) gives the vectorised rates bit for bit."""
    from odorloc.models.vergassola import vergassola_rate

    rng = np.random.default_rng(5)
    src = rng.uniform([5, 5, 5], [95, 55, 25], (n_sources, 3)).tolist()
    plume = _rate_plume(velocity, src)
    p = plume.params
    for q in (1, 3, 8):
        pts = rng.uniform([0, 0, 0], [100, 60, 30], (q, 3))
        pts[0] = src[0]  # at a source: the floored distance
        fast = plume.encounter_rate(pts)
        ref = vergassola_rate(
            pts,
            plume.source_positions,
            [s.rate for s in plume.sources],
            V=plume.V,
            D=p.D,
            tau=p.tau,
            a=p.sensor_radius,
            direction=plume.direction,
        ).sum(axis=1)
        assert np.array_equal(fast, ref)


def test_steady_rate_plume_ticks_only_its_clock() -> None:
    """A rate plume in a steady wind with constant sources keeps its rates when stepped (and its
    clock runs); a modulated source still changes them."""
    steady = _rate_plume((0.0, -1.0, 0.0), [[10.0, 30.0, 25.0]])
    pt = np.array([[10.0, 20.0, 24.0]])
    before = steady.encounter_rate(pt)
    rng = np.random.default_rng(0)
    for _ in range(5):
        steady.step(0.5, rng)
    assert steady.t == pytest.approx(2.5)
    assert np.array_equal(steady.encounter_rate(pt), before)
    pulsed = _rate_plume(
        (0.0, -1.0, 0.0), [[10.0, 30.0, 25.0]], {"kind": "onoff", "period": 2.0, "duty": 0.5}
    )
    seen = set()
    for _ in range(4):
        seen.add(float(pulsed.encounter_rate(pt)[0]))
        pulsed.step(0.5, rng)
    assert len(seen) == 2 and 0.0 in seen


def test_reach_test_matches_the_array_norm() -> None:
    """The reach test finds the first (agent, source) pair within the radius in agent-major
    order, with the distances numpy.linalg.norm computes."""
    from odorloc.engine.episode import first_within

    rng = np.random.default_rng(2)
    for _ in range(300):
        d = int(rng.integers(2, 4))
        pos = rng.uniform(0, 10, (int(rng.integers(1, 6)), d))
        src = rng.uniform(0, 10, (int(rng.integers(1, 4)), d))
        radius = float(rng.uniform(0.5, 4.0))
        if rng.random() < 0.3:  # exactly on the circle
            radius = float(np.linalg.norm(pos[0] - src[-1]))
        got = first_within(pos, src.tolist(), radius)
        hits = np.argwhere(np.linalg.norm(pos[:, None, :] - src[None, :, :], axis=2) <= radius)
        assert got == (tuple(int(v) for v in hits[0]) if len(hits) else None)
