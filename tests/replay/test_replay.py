"""Recorded data: ROS bags (written with rosbags itself from one of our plumes, read back),
GADEN simulations (round trip, the line-of-sight rule, bad files), estimators replayed offline."""

from __future__ import annotations

import shutil
import zlib

import numpy as np
import pytest

from odorloc import checks
from odorloc.core.errors import ConfigError
from odorloc.engine.episode import prepare_world, run_episode
from odorloc.geometry.arena import Arena
from odorloc.replay.gaden import (
    GadenSimulation,
    GadenWriter,
    read_occupancy,
    record_gaden,
    write_occupancy,
)
from odorloc.replay.offline import replay_estimator
from odorloc.scenarios import Scenario
from odorloc.viz.episode import plot_belief_map

MAPPING = {
    "period": 0.5,
    "gas": {"topic": "/gas", "threshold": 0.5, "reduce": "max"},
    "anemometer": {"topic": "/wind"},
    "pose": {"topic": "/pose"},
    "arena": {"lower": [0.0, 0.0], "upper": [10.0, 6.0]},
    "sources": [[1.5, 3.0]],
}


@pytest.fixture(scope="module")
def episode():
    sc = checks.small_scenario({"type": "zigzag"}, 2, 1, 30.0)
    return run_episode(sc, 1, 2, record=True)


# ---------------------------------------------------------------------- bags
@pytest.mark.parametrize("version", [1, 2])
def test_bag_round_trip(tmp_path, episode, version: int) -> None:
    pytest.importorskip("rosbags")
    from odorloc.replay.bag import BagLog, write_bag

    rec = episode.recording
    path = tmp_path / ("run.bag" if version == 1 else "run")
    write_bag(path, rec, MAPPING, version=version, gas_rate=3)
    log = BagLog(path, MAPPING)
    obs = list(log.observations())
    assert len(obs) == len(rec.t)
    np.testing.assert_array_equal([o.position for o in obs], rec.positions[:, 0])
    np.testing.assert_array_equal([o.wind for o in obs], rec.wind[:, 0])
    # std_msgs/Float32 carries the reading: float32 rounding only
    np.testing.assert_allclose([o.gas for o in obs], rec.gas[:, 0], rtol=1e-6, atol=1e-6)
    np.testing.assert_array_equal([o.t for o in obs], rec.t)
    assert [o.detection for o in obs] == list(rec.gas[:, 0].astype(np.float32) >= 0.5)
    ctx = log.context()
    assert ctx.arena.lower == (0.0, 0.0) and ctx.dt == 0.5 and ctx.gas_threshold == 0.5


def test_bag_gas_reduction_and_body_frame(tmp_path, episode) -> None:
    pytest.importorskip("rosbags")
    from odorloc.replay.bag import BagLog, write_bag

    rec = episode.recording
    # three different readings per period: each reduction picks its own
    base = rec.gas[:, 0]
    samples = base[:, None] + np.array([[0.25, 0.75, -0.125]])
    write_bag(tmp_path / "r", rec, MAPPING, gas_rate=3, gas_samples=samples)
    for how, want in (
        ("last", base - 0.125),
        ("mean", base + 0.875 / 3),
        ("max", base + 0.75),
    ):
        m = {**MAPPING, "gas": {**MAPPING["gas"], "reduce": how}}
        g = [o.gas for o in BagLog(tmp_path / "r", m).observations()]
        np.testing.assert_allclose(g, want, rtol=1e-6, atol=1e-6, err_msg=how)
    with pytest.raises(ConfigError, match="gas_samples"):
        write_bag(tmp_path / "bad", rec, MAPPING, gas_rate=2, gas_samples=samples)
    write_bag(tmp_path / "b", rec, MAPPING, gas_rate=2)
    body = {**MAPPING, "anemometer": {"topic": "/wind", "frame": "body"}}
    obs = list(BagLog(tmp_path / "b", body).observations())
    for o, w in zip(obs[:10], rec.wind[:10, 0], strict=True):
        c, s = np.cos(o.heading), np.sin(o.heading)
        np.testing.assert_allclose(o.wind, [c * w[0] - s * w[1], s * w[0] + c * w[1]])


def test_bag_errors_name_the_field(tmp_path, episode) -> None:
    pytest.importorskip("rosbags")
    from odorloc.replay.bag import BagLog, write_bag

    write_bag(tmp_path / "b", episode.recording, MAPPING)
    with pytest.raises(ConfigError) as ei:
        BagLog(tmp_path / "b", {**MAPPING, "gas": {"topic": "/odor"}})
    assert ei.value.field == "gas.topic" and "/gas" in ei.value.problem
    with pytest.raises(ConfigError) as ei:
        BagLog(
            tmp_path / "b",
            {**MAPPING, "pose": {"topic": "/pose", "msgtype": "nav_msgs/msg/Odometry"}},
        )
    assert ei.value.field == "pose.msgtype" and "PoseStamped" in ei.value.problem
    with pytest.raises(ConfigError) as ei:
        BagLog(tmp_path / "b", {**MAPPING, "gas": {"topic": "/gas", "field": "raw"}})
    assert ei.value.field == "gas.field" and "Float32" in ei.value.problem
    with pytest.raises(ConfigError) as ei:  # a pose topic read as a gas reading
        BagLog(tmp_path / "b", {**MAPPING, "gas": {"topic": "/pose", "field": "header"}})
    assert ei.value.field == "gas.field" and "not a number" in ei.value.problem
    with pytest.raises(ConfigError) as ei:
        BagLog(tmp_path / "b", {**MAPPING, "period": -1})
    assert ei.value.field == "period"
    with pytest.raises(ConfigError, match="does not exist"):
        BagLog(tmp_path / "nothing", MAPPING)
    (tmp_path / "junk.bag").write_bytes(b"not a bag at all")
    with pytest.raises(ConfigError, match="not a readable ROS bag"):
        BagLog(tmp_path / "junk.bag", MAPPING)


def _bag(path, msgs) -> None:
    """A ROS 2 bag of ``(topic, t s, payload)`` messages: ``/gas`` a float, ``/wind`` an
    ``(x, y, z)`` vector, ``/pose`` ``((x, y, z), yaw)`` or ``/point`` ``(x, y, z)``."""
    from rosbags.rosbag2 import Writer
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.ROS2_HUMBLE)
    T = ts.types
    kinds = {
        "/gas": "std_msgs/msg/Float32",
        "/wind": "geometry_msgs/msg/Vector3Stamped",
        "/pose": "geometry_msgs/msg/PoseStamped",
        "/point": "geometry_msgs/msg/PointStamped",
    }

    def header(ns: int):
        stamp = T["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9)
        return T["std_msgs/msg/Header"](stamp=stamp, frame_id="map")

    conns = {}
    with Writer(path, version=9) as w:
        for topic, t, v in sorted(msgs, key=lambda m: m[1]):
            ns = 10**12 + round(t * 1e9)
            if topic not in conns:
                conns[topic] = w.add_connection(topic, kinds[topic], typestore=ts)
            if topic == "/gas":
                msg = T["std_msgs/msg/Float32"](data=float(v))
            elif topic == "/wind":
                vec = T["geometry_msgs/msg/Vector3"](x=v[0], y=v[1], z=v[2])
                msg = T["geometry_msgs/msg/Vector3Stamped"](header=header(ns), vector=vec)
            elif topic == "/point":
                pt = T["geometry_msgs/msg/Point"](x=v[0], y=v[1], z=v[2])
                msg = T["geometry_msgs/msg/PointStamped"](header=header(ns), point=pt)
            else:
                (x, y, z), yaw = v
                q = T["geometry_msgs/msg/Quaternion"](
                    x=0.0, y=0.0, z=np.sin(yaw / 2), w=np.cos(yaw / 2)
                )
                pt = T["geometry_msgs/msg/Point"](x=x, y=y, z=z)
                pose = T["geometry_msgs/msg/Pose"](position=pt, orientation=q)
                msg = T["geometry_msgs/msg/PoseStamped"](header=header(ns), pose=pose)
            w.write(conns[topic], ns, ts.serialize_cdr(msg, kinds[topic]))


LINE = {
    "period": 0.5,
    "gas": {"topic": "/gas", "reduce": "last"},
    "anemometer": {"topic": "/wind"},
    "pose": {"topic": "/pose"},
}


def _line(k: int, offset: float, gas: bool = True) -> list:
    """A robot at x = k m at t = k/2 s; the reading taken there (value k), ``offset`` s late."""
    msgs = [("/pose", 0.5 * k, ((float(k), 0.0, 0.0), 0.0)), ("/wind", 0.5 * k, (1.0, 0, 0))]
    return msgs + ([("/gas", 0.5 * k + offset, float(k))] if gas else [])


@pytest.mark.parametrize("offset", [0.0, 0.01, -0.01, 0.2, -0.2])
def test_bag_pairs_each_reading_with_where_it_was_taken(tmp_path, offset: float) -> None:
    pytest.importorskip("rosbags")
    from odorloc.replay.bag import BagLog

    _bag(tmp_path / "b", [m for k in range(12) for m in _line(k, offset)])
    obs = list(BagLog(tmp_path / "b", LINE).observations())
    assert len(obs) >= 10
    # the value of a reading is the x where it was taken: the pose at the reading's time (a
    # reading after the last pose is placed at it)
    late = offset > 0 and obs[-1].gas == 11
    inner = obs[:-1] if late else obs
    np.testing.assert_allclose([o.position[0] - o.gas for o in inner], 2 * offset, atol=1e-6)
    assert not late or obs[-1].position[0] == 11.0
    np.testing.assert_array_equal([o.t for o in obs], 0.5 * np.arange(len(obs)))


def test_bag_headings_follow_the_path(tmp_path, episode) -> None:
    pytest.importorskip("rosbags")
    from types import SimpleNamespace

    from odorloc.replay.bag import BagLog, _yaw, write_bag

    rec = episode.recording
    write_bag(tmp_path / "b", rec, MAPPING)
    obs = list(BagLog(tmp_path / "b", MAPPING).observations())
    steps = np.diff(rec.positions[:, 0], axis=0)
    moving = np.hypot(steps[:, 0], steps[:, 1]) > 1e-9
    want = np.arctan2(steps[:, 1], steps[:, 0])[moving]
    got = np.array([o.heading for o in obs[:-1]])[moving]
    assert moving.sum() > 10
    np.testing.assert_allclose(np.angle(np.exp(1j * (got - want))), 0.0, atol=1e-6)
    # a quaternion that is not normalised has the same heading
    q = SimpleNamespace(x=0.0, y=0.0, z=2 * np.sin(np.pi / 4), w=2 * np.cos(np.pi / 4))
    assert _yaw(q) == pytest.approx(np.pi / 2)


def test_bag_bad_data_is_named_before_any_estimator_runs(tmp_path, episode) -> None:
    pytest.importorskip("rosbags")
    from odorloc.replay.bag import BagLog, write_bag

    # the gas sensor falls silent after 3 periods
    _bag(tmp_path / "quiet", [m for k in range(10) for m in _line(k, 0.0, gas=k < 3)])
    log = BagLog(tmp_path / "quiet", LINE)
    with pytest.raises(ConfigError, match="no reading in period 3") as ei:
        log.context()
    assert ei.value.field == "gas.topic"
    held = list(
        BagLog(
            tmp_path / "quiet", {**LINE, "gas": {**LINE["gas"], "missing": "hold"}}
        ).observations()
    )
    assert [o.gas for o in held][:5] == [0.0, 1.0, 2.0, 2.0, 2.0]
    # non-finite values
    for name, bad in (
        ("gas", ("/gas", 1.0, float("nan"))),
        ("pose", ("/pose", 1.0, ((np.inf, 0, 0), 0.0))),
    ):
        msgs = [m for k in range(6) for m in _line(k, 0.0) if m[:2] != bad[:2]] + [bad]
        _bag(tmp_path / name, msgs)
        with pytest.raises(ConfigError, match="not finite") as ei:
            BagLog(tmp_path / name, LINE).context()
        assert ei.value.field == f"{name}.field"
    # a body-frame wind needs an orientation to turn it by
    pts = [(t, s, v[0]) if t == "/pose" else (t, s, v) for k in range(4) for t, s, v in _line(k, 0)]
    _bag(tmp_path / "pt", [("/point" if t == "/pose" else t, s, v) for t, s, v in pts])
    body = {**LINE, "pose": {"topic": "/point", "field": "point"}}
    assert [o.heading for o in BagLog(tmp_path / "pt", body).observations()] == [0.0] * 4
    with pytest.raises(ConfigError) as ei:
        BagLog(tmp_path / "pt", {**body, "anemometer": {"topic": "/wind", "frame": "body"}})
    assert ei.value.field == "anemometer.frame"
    # sources and arena that do not fit the log
    write_bag(tmp_path / "ok", episode.recording, MAPPING)
    with pytest.raises(ConfigError) as ei:
        BagLog(tmp_path / "ok", {**MAPPING, "sources": [[1.5, 3.0, 1.0]]})
    assert ei.value.field == "sources[0]"
    with pytest.raises(ConfigError, match="units") as ei:  # millimetres read as metres
        BagLog(
            tmp_path / "ok", {**MAPPING, "arena": {"lower": [0, 0], "upper": [0.01, 0.006]}}
        ).context()
    assert ei.value.field == "arena"
    with pytest.raises(ConfigError) as ei:
        BagLog(tmp_path / "ok", {**MAPPING, "sources": [[15.0, 3.0]]}).context()
    assert ei.value.field == "sources[0]"
    # a bag written at another period than the mapping says
    with pytest.raises(ConfigError) as ei:
        write_bag(tmp_path / "p", episode.recording, {**MAPPING, "period": 0.25})
    assert ei.value.field == "period"


@pytest.mark.parametrize("estimator", ["pf-entropy", "ds-rectangular-wave", "odor-path"])
def test_estimators_replay_over_a_bag(tmp_path, episode, estimator: str) -> None:
    pytest.importorskip("rosbags")
    from odorloc.replay.bag import BagLog, write_bag

    write_bag(tmp_path / "b", episode.recording, MAPPING)
    log = BagLog(tmp_path / "b", MAPPING)
    rec = replay_estimator(
        log.observations(), log.context(), estimator, sources=np.array([[1.5, 3.0]])
    )
    assert rec.beliefs and rec.positions.shape == episode.recording.positions.shape
    # every estimator localises the source of this log to within a metre
    assert rec.meta["loc_error"] < 1.0, rec.meta
    fig_path = tmp_path / "belief.png"
    plot_belief_map(rec, fig_path)
    assert fig_path.stat().st_size > 10_000


def test_offline_replay_is_deterministic_per_seed(episode) -> None:
    from odorloc.core.types import Observation

    rec = episode.recording
    obs = [
        Observation(0, float(t), p, 0.0, float(g), bool(d), w)
        for t, p, g, d, w in zip(
            rec.t,
            rec.positions[:, 0],
            rec.gas[:, 0],
            rec.detection[:, 0],
            rec.wind[:, 0],
            strict=True,
        )
    ]
    from odorloc.scenarios.build import build, search_context

    sc = checks.small_scenario({"type": "zigzag"}, 2, 1, 30.0)
    ctx = search_context(sc, build(sc))
    a = replay_estimator(obs, ctx, "pf-entropy", seed=4)
    b = replay_estimator(obs, ctx, "pf-entropy", seed=4)
    np.testing.assert_array_equal(a.beliefs[-1][1]["positions"], b.beliefs[-1][1]["positions"])
    with pytest.raises(ConfigError, match="no observations"):
        replay_estimator([], ctx)


def test_a_recipe_replays_its_estimator(episode) -> None:
    """A searcher's name replays the estimator it composes, with its model and parameters: the
    same as naming the estimator; a searcher without one is refused before any log is read."""
    from odorloc.core.types import Observation
    from odorloc.replay.offline import check_estimator, resolve_estimator
    from odorloc.scenarios.build import build, search_context

    rec = episode.recording
    obs = [
        Observation(0, float(t), p, 0.0, float(g), bool(d), w)
        for t, p, g, d, w in zip(
            rec.t,
            rec.positions[:, 0],
            rec.gas[:, 0],
            rec.detection[:, 0],
            rec.wind[:, 0],
            strict=True,
        )
    ]
    sc = checks.small_scenario({"type": "zigzag"}, 2, 1, 30.0)
    ctx = search_context(sc, build(sc))
    a = replay_estimator(obs, ctx, "pf-entropy", seed=4)
    b = replay_estimator(obs, ctx, "particle-filter", seed=4)
    assert a.beliefs and len(a.beliefs) == len(b.beliefs)
    np.testing.assert_array_equal(a.beliefs[-1][1]["positions"], b.beliefs[-1][1]["positions"])
    assert a.meta["searcher"] == "pf-entropy" and b.meta["searcher"] == "particle-filter"
    grid = replay_estimator(obs, ctx, "ds-map")
    assert grid.beliefs and "m_s" in grid.beliefs[-1][1]
    check_estimator("odor-path")
    with pytest.raises(ConfigError) as ei:
        check_estimator("no-such-thing", "--estimator")
    assert ei.value.field == "--estimator"
    with pytest.raises(ConfigError, match="composes no estimator"):
        resolve_estimator("zigzag")


# ---------------------------------------------------------------------- GADEN
def _gaden_scenario() -> Scenario:
    sc = checks.small_scenario({"type": "zigzag"}, 3, 1, 20.0)
    return sc.with_overrides(
        {
            "world.plume.cutoff": 5.0,  # GADEN's player counts filaments up to 5 sigma
            "world.arena.obstacles.boxes": [[[4.0, 0.0, 0.0], [4.5, 3.0, 4.0]]],
        }
    )


@pytest.fixture(scope="module")
def gaden_dir(tmp_path_factory):
    d = tmp_path_factory.mktemp("gaden") / "sim"
    record_gaden(_gaden_scenario(), 5, d, 5.0, 0.5)
    return d


def test_gaden_round_trip_of_our_filament_plume(gaden_dir) -> None:
    sc = _gaden_scenario()
    sim = GadenSimulation(gaden_dir)
    assert sim.n_frames == 11 and sim.header.version == (2, 4)
    assert sim.shape == (40, 24, 16) and sim.cell == 0.25
    world, rng, _ = prepare_world(sc, 5)
    pts = np.random.default_rng(0).uniform([0, 0, 0], [10, 6, 4], (400, 3))
    for k in range(sim.n_frames):
        if k:
            for _ in range(5):
                world.step(0.1, rng)
        fr = sim.frame(k)
        np.testing.assert_array_equal(fr.positions, world.plume.positions)
        np.testing.assert_allclose(fr.sigma_cm / 100, np.sqrt(world.plume.sigma2), rtol=1e-15)
        q = np.vstack([pts, world.plume.positions[:50] + 0.03])
        # without the occupancy grid GADEN's rule is our kernel sum (5-sigma cutoff)
        np.testing.assert_allclose(
            sim.concentration(k, q), world.plume.concentration(q), rtol=1e-9, atol=1e-12
        )
        np.testing.assert_array_equal(sim.wind_at(k, pts), world.wind.velocity(pts))


def test_gaden_line_of_sight_rule(tmp_path) -> None:
    arena = Arena((0.0, 0.0, 0.0), (6.0, 4.0, 3.0), 0.2).with_boxes(
        [((2.8, 0.0, 0.0), (3.2, 4.0, 3.0))]
    )
    w = GadenWriter(tmp_path / "s", arena, (1.0, 2.0, 1.5), amount=2.0)

    class Calm:
        def velocity(self, p):
            return np.zeros((len(p), 3))

    wi = w.write_wind(Calm())
    w.write_frame(np.array([[2.5, 2.0, 1.5]]), np.array([0.4]), wi)
    occ = tmp_path / "s" / "OccupancyGrid3D.csv"
    blind = GadenSimulation(tmp_path / "s")
    seeing = GadenSimulation(tmp_path / "s", occupancy=occ)
    here, behind = np.array([[2.1, 2.0, 1.5]]), np.array([[3.5, 2.0, 1.5]])
    expected = 2.0 * (2 * np.pi * 0.16) ** -1.5 * np.exp(-0.5 * 0.16 / 0.16)
    assert blind.concentration(0, here)[0] == pytest.approx(expected, rel=1e-12)
    assert seeing.concentration(0, here)[0] == pytest.approx(expected, rel=1e-12)
    assert blind.concentration(0, behind)[0] > 0
    assert seeing.concentration(0, behind)[0] == 0.0  # the wall hides the filament
    assert seeing.concentration(0, np.array([[3.0, 2.0, 1.5]]))[0] == 0.0  # inside the wall
    assert blind.concentration(0, np.array([[7.0, 2.0, 1.5]]))[0] == 0.0  # outside


def test_occupancy_grid_round_trip(tmp_path) -> None:
    g = np.random.default_rng(1).integers(0, 3, (5, 4, 3)).astype(np.uint8)
    p = write_occupancy(tmp_path / "o.csv", g, (1.0, -2.0, 0.0), 0.5)
    back, lo, cell = read_occupancy(p)
    np.testing.assert_array_equal(back, g)
    assert lo.tolist() == [1.0, -2.0, 0.0] and cell == 0.5
    text = p.read_text().splitlines()
    assert text[2] == "#num_cells 5 4 3" and text[4].split() == [str(v) for v in g[0, :, 0]]
    p.write_text("\n".join(text[:-3]) + "\n")
    with pytest.raises(ConfigError, match="truncated"):
        read_occupancy(p)


def test_gaden_scenario_runs_an_episode(gaden_dir) -> None:
    sc = checks.small_scenario({"type": "zigzag"}, 3, 1, 8.0)
    data = sc.to_dict()
    occ = str(gaden_dir / "OccupancyGrid3D.csv")
    data["world"]["wind"] = {"type": "odorloc.replay.gaden:GadenWind", "path": str(gaden_dir)}
    data["world"]["plume"] = {
        "type": "odorloc.replay.gaden:GadenPlume",
        "path": str(gaden_dir),
        "occupancy": occ,
        "verify": True,
    }
    data["world"]["warmup"] = 0.0
    res = run_episode(Scenario.from_dict(data), 1, 2, record=True)
    assert res.metrics["termination"] == "time_limit"
    assert res.recording.plume_frames.max() > 0
    data["world"]["plume"]["path"] = str(gaden_dir.parent / "missing")
    from odorloc.scenarios.build import build

    with pytest.raises(ConfigError) as ei:
        build(Scenario.from_dict(data))
    assert ei.value.field == "world.plume.path" and "does not exist" in ei.value.problem


def _copy(src, dst):
    shutil.copytree(src, dst)
    return dst


def test_gaden_bad_files_give_one_line_errors(gaden_dir, tmp_path) -> None:
    d = _copy(gaden_dir, tmp_path / "bad")
    raw = (d / "iteration_3").read_bytes()
    (d / "iteration_3").write_bytes(raw[: len(raw) // 2])
    sim = GadenSimulation(d)  # frame 0 is fine; frame 3 is read when reached
    with pytest.raises(ConfigError, match="iteration_3: truncated frame file"):
        sim.frame(3)
    with pytest.raises(ConfigError, match="truncated"):
        sim.verify()
    (d / "iteration_3").write_bytes(b"\x00garbage" + raw[8:])
    with pytest.raises(ConfigError, match="iteration_3: corrupted frame file"):
        GadenSimulation(d).frame(3)
    body = zlib.decompress(raw) + b"\x01\x02\x03"
    (d / "iteration_3").write_bytes(zlib.compress(body))
    with pytest.raises(ConfigError, match="not a multiple of 36"):
        GadenSimulation(d).frame(3)
    (d / "iteration_0").write_bytes(zlib.compress(b"\x07\x00\x00\x00" + body[4:]))
    with pytest.raises(ConfigError, match="unknown log version 7"):
        GadenSimulation(d)
    d2 = _copy(gaden_dir, tmp_path / "nowind")
    (d2 / "wind" / "wind_iteration_0").unlink()
    with pytest.raises(ConfigError, match="wind file is missing"):
        GadenSimulation(d2)
    (d2 / "wind" / "wind_iteration_0").write_bytes(b"\x00" * 80)
    with pytest.raises(ConfigError, match="expected 3 x"):
        GadenSimulation(d2).wind(0)
    with pytest.raises(ConfigError, match="does not match"):
        other = tmp_path / "occ.csv"
        write_occupancy(other, np.zeros((3, 3, 3), np.uint8), (0, 0, 0), 0.25)
        GadenSimulation(gaden_dir, occupancy=other)


def test_gaden_missing_iteration_is_named(gaden_dir, tmp_path) -> None:
    d = _copy(gaden_dir, tmp_path / "gap")
    (d / "iteration_2").unlink()  # a partial copy: later frames would show too early
    with pytest.raises(ConfigError, match="iteration_2 is missing"):
        GadenSimulation(d)
    assert GadenSimulation(d, first_iteration=3).iterations[0] == 3


def test_gaden_frames_are_decoded_lazily(gaden_dir) -> None:
    sim = GadenSimulation(gaden_dir)
    seen = [len(fr.sigma_cm) for fr in sim.frames()]
    assert len(seen) == sim.n_frames and seen == sorted(seen)  # the plume grows
    # only the last decoded frame is kept
    assert sim.frame(sim.n_frames - 1) is sim.frame(sim.n_frames - 1)


def test_cli_replay_log(tmp_path, episode) -> None:
    pytest.importorskip("rosbags")
    import yaml
    from typer.testing import CliRunner

    from odorloc.cli import app
    from odorloc.replay.bag import write_bag

    write_bag(tmp_path / "b", episode.recording, MAPPING)
    topics = tmp_path / "topics.yaml"
    topics.write_text(yaml.safe_dump(MAPPING))
    out = tmp_path / "out"
    r = CliRunner().invoke(
        app, ["replay-log", str(tmp_path / "b"), "--topics", str(topics), "--out", str(out)]
    )
    assert r.exit_code == 0, r.output
    assert (out / "belief.png").stat().st_size > 0 and (out / "recording.npz").stat().st_size > 0
    bad = {**MAPPING, "anemometer": {"topic": "/anemo"}}
    topics.write_text(yaml.safe_dump(bad))
    r = CliRunner().invoke(app, ["replay-log", str(tmp_path / "b"), "--topics", str(topics)])
    assert r.exit_code == 2
    assert "anemometer.topic" in r.output and "Traceback" not in r.output


def _replay_log(*args: str):
    from typer.testing import CliRunner

    from odorloc.cli import app

    return CliRunner().invoke(app, ["replay-log", *args])


def test_cli_replay_log_unreadable_bag_is_one_line(tmp_path) -> None:
    """A plain file, or a folder without a ROS 2 metadata.yaml, is refused like a garbage .bag:
    one ``bag:`` line, exit 2."""
    pytest.importorskip("rosbags")
    import yaml

    topics = tmp_path / "topics.yaml"
    topics.write_text(yaml.safe_dump(MAPPING))
    (tmp_path / "afile").write_text("not a bag\n")
    (tmp_path / "nometa").mkdir()
    out = tmp_path / "out"
    for bag in ("afile", "nometa"):
        r = _replay_log(str(tmp_path / bag), "--topics", str(topics), "--out", str(out))
        assert r.exit_code == 2, (r.output, r.exception)
        assert r.stderr.startswith("error: bag: ") and "is not a readable ROS bag" in r.stderr
        assert len(r.stderr.strip().splitlines()) == 1, r.stderr
    assert not out.exists()


@pytest.mark.parametrize(
    ("change", "args", "expect"),
    [
        ({}, ["--estimator", "nosuch"], "error: --estimator: unknown searcher 'nosuch'"),
        (
            {"arena": {"lower": [float("nan"), 0.0], "upper": [10.0, 6.0]}},
            [],
            "error: arena.lower: ",
        ),
        (
            {"gas": {**MAPPING["gas"], "threshold": float("nan")}},
            [],
            "error: gas.threshold: must be finite",
        ),
        ({"sources": [[True, 3.0]]}, [], "error: sources[0]: "),
    ],
)
def test_cli_replay_log_checks_options_and_topics_before_reading_the_bag(
    tmp_path, episode, monkeypatch, change, args, expect
) -> None:
    """An unknown estimator and a bad static field of the topics file (a NaN bound, a NaN
    threshold that would detect nothing, true read as 1.0) are named before the bag is read."""
    pytest.importorskip("rosbags")
    import yaml

    from odorloc.replay.bag import BagLog, write_bag

    write_bag(tmp_path / "b", episode.recording, MAPPING)
    topics = tmp_path / "topics.yaml"
    topics.write_text(yaml.safe_dump({**MAPPING, **change}))

    def never(self):
        raise AssertionError("the bag was read before its settings were checked")

    monkeypatch.setattr(BagLog, "observations", never)
    out = tmp_path / "out"
    r = _replay_log(str(tmp_path / "b"), "--topics", str(topics), *args, "--out", str(out))
    assert r.exit_code == 2, (r.output, r.exception)
    assert r.stderr.startswith(expect), r.stderr
    assert len(r.stderr.strip().splitlines()) == 1, r.stderr
    assert not out.exists()
