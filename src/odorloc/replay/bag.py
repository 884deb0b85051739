"""Recorded robot logs from ROS 1 and ROS 2 bags (pure Python, ``rosbags``; extra ``odorloc[ros]``).

A small YAML maps the bag's topics and message fields onto what odorloc reads::

    period: 0.5                  # control period of the recording, seconds
    dim: 2                       # 2 or 3 (a 2-D log uses x, y of poses and winds)
    gas:
      topic: /gas_sensor
      field: raw                 # dotted path to a number in the message
      threshold: 2.0             # detection threshold, reading units
      reduce: max                # readings within a period: last, mean or max
    anemometer:
      topic: /anemometer
      field: vector              # a vector (x, y, z) in the message ...
      # speed: wind_speed        # ... or a speed and a direction (rad) field
      # direction: wind_direction
      # direction_is: towards    # the direction the air moves to (or "from")
      frame: world               # world, or body (rotated by the robot's heading)
    pose:
      topic: /odom
      field: pose.pose           # a Pose (position + orientation) or a Point
    arena: {lower: [0, 0], upper: [10, 6]}   # optional; default: the path's extent + margin
    margin: 1.0                  # metres around the path's extent when no arena is given
    sources: [[1.5, 3.0]]        # optional true sources (scored and drawn)
    success_radius: 0.5          # an estimate this close (metres) finds a true source

:class:`BagLog` checks the topics, their message types and fields when opened (one clear line
naming the mapping field on a missing topic, a wrong message type, a missing field, a type the
bag cannot decode, or a body-frame wind without an orientation to turn it by) and then streams
the bag; it is never loaded whole.

Periods: period ``k`` covers ``[s + k T, s + (k + 1) T)`` of bag time, ``s`` the time at which
every topic has spoken once and ``T`` the ``period``. :meth:`BagLog.observations` yields one
:class:`~odorloc.core.types.Observation` per period: the period's gas readings reduced by
``gas.reduce``, the position where that value was read (the pose interpolated linearly in time
at the reading's stamp: the last reading's for ``last``, the largest's for ``max``, the mean
stamp for ``mean``; the heading of the nearer pose), and the latest wind of the period. Pairing
by time keeps a reading with the place it was taken whichever topic speaks first. A period
without a gas reading is an error naming it (``gas.missing: error``), or holds the last reading
(``gas.missing: hold``, for a sensor slower than the period). :meth:`BagLog.context` reads the
whole bag once first, so that a non-finite value, a gap or a path outside the arena is reported
before any estimator runs.
:func:`write_bag` writes an odorloc recording as such a bag (ROS 1 or ROS 2), so data moves both
ways.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from pathlib import Path
from typing import Any, Literal

import numpy as np
import pydantic
from pydantic import Field

from odorloc.core.errors import ConfigError, format_validation_error
from odorloc.core.loading import load_yaml_mapping
from odorloc.core.params import Finite, Params, Positive, Vector
from odorloc.core.types import Observation, SearchContext, SensorInfo
from odorloc.geometry.arena import Arena

__all__ = ["BagLog", "BagMapping", "load_mapping", "write_bag"]


class GasTopic(Params):
    """The gas-sensor topic: a numeric ``field``, the detection ``threshold`` and how readings
    within one period are reduced."""

    topic: str
    field: str = "data"
    msgtype: str | None = None
    # NaN would compare false with every reading: a log without a single detection
    threshold: Finite = 0.0
    reduce: Literal["last", "mean", "max"] = "last"
    missing: Literal["error", "hold"] = "error"


class WindTopic(Params):
    """The anemometer topic: a vector ``field`` or ``speed`` + ``direction`` fields."""

    topic: str
    field: str | None = "vector"
    speed: str | None = None
    direction: str | None = None
    direction_is: Literal["towards", "from"] = "towards"
    frame: Literal["world", "body"] = "world"
    msgtype: str | None = None


class PoseTopic(Params):
    """The pose topic: ``field`` leads to a Pose (``position``, ``orientation``) or a Point."""

    topic: str
    field: str = "pose"
    msgtype: str | None = None


class ArenaBox(Params):
    """Bounds of the map, metres."""

    lower: Vector
    upper: Vector
    resolution: Positive = 0.1

    @pydantic.model_validator(mode="after")
    def _check_box(self) -> ArenaBox:
        if len(self.upper) != len(self.lower):
            raise ConfigError("upper", f"has {len(self.upper)} components, lower {len(self.lower)}")
        if any(h <= lo for lo, h in zip(self.lower, self.upper, strict=True)):
            raise ConfigError(
                "upper", f"must exceed lower in every axis ({self.upper} vs {self.lower})"
            )
        return self


class BagMapping(Params):
    """How a bag's topics become odorloc observations (see the module docstring)."""

    period: Positive = 0.5
    dim: Literal[2, 3] = 2
    gas: GasTopic
    anemometer: WindTopic
    pose: PoseTopic
    arena: ArenaBox | None = None
    margin: Positive = 1.0
    """Without ``arena``, the search area is the path's extent plus this, metres."""
    # true/false refused: YAML would read them as 1 and 0
    sources: list[Vector] = Field(default_factory=list)
    success_radius: Positive = 0.5
    """A true source counts as found when an estimate lies this close, metres."""
    max_speed: Positive = 1.0

    @pydantic.model_validator(mode="after")
    def _check_dims(self) -> BagMapping:
        # checked with the file, before the bag is read (BagLog.context reads it whole)
        if self.arena is not None and len(self.arena.lower) != self.dim:
            raise ConfigError(
                "arena.lower", f"has {len(self.arena.lower)} components, the log is {self.dim}-D"
            )
        for i, src in enumerate(self.sources):
            if len(src) != self.dim:
                raise ConfigError(
                    f"sources[{i}]", f"has {len(src)} components, the log is {self.dim}-D"
                )
        return self


def load_mapping(source: str | Path | dict[str, Any] | BagMapping) -> BagMapping:
    """A :class:`BagMapping` from a YAML file, a dict or itself; :class:`ConfigError` if bad."""
    if isinstance(source, BagMapping):
        return source
    data: Any = source
    if not isinstance(source, dict):
        # the same guarded reader as scenarios and sweeps (encoding, size, aliases, depth)
        data = load_yaml_mapping(Path(source), "topics")
    if not isinstance(data, dict):
        raise ConfigError("topics", "the topic mapping must be a mapping")
    try:
        return BagMapping.model_validate(data)
    except pydantic.ValidationError as err:
        fld, _, problem = format_validation_error(err).partition(": ")
        raise ConfigError(fld, problem) from None


def _resolve(msg: Any, path: str) -> Any:
    obj = msg
    for part in path.split("."):
        if not part:
            continue
        obj = getattr(obj, part)
    return obj


def _number(v: Any) -> bool:
    return isinstance(v, int | float | np.number) and not isinstance(v, bool)


def _vector(v: Any) -> np.ndarray:
    return np.array([float(v.x), float(v.y), float(v.z)])


def _yaw(q: Any) -> float:
    """Heading (rad) of a quaternion (ZYX yaw); the quaternion need not be normalised."""
    w, x, y, z = float(q.w), float(q.x), float(q.y), float(q.z)
    return math.atan2(2.0 * (w * z + x * y), w * w + x * x - y * y - z * z)


class BagLog:
    """A ROS 1 (``.bag``) or ROS 2 (folder) bag read as a stream of observations.

    Parameters
    ----------
    path : str or Path
        The bag.
    mapping : path, dict or BagMapping
        Topic mapping (see the module docstring).
    """

    def __init__(self, path: str | Path, mapping: str | Path | dict[str, Any] | BagMapping):
        from rosbags.highlevel import AnyReader
        from rosbags.typesys import Stores, get_typestore

        self.path = Path(path)
        self.mapping = m = load_mapping(mapping)
        if not self.path.exists():
            raise ConfigError("bag", f"{self.path} does not exist")
        self._typestore = get_typestore(Stores.ROS2_HUMBLE)
        self._reader_cls = AnyReader
        with self._open() as reader:
            self._t_origin = reader.start_time * 1e-9
            topics = {c.topic: c for c in reader.connections}
            self.connections = {}
            for key, spec in (("gas", m.gas), ("anemometer", m.anemometer), ("pose", m.pose)):
                conn = topics.get(spec.topic)
                if conn is None:
                    known = ", ".join(sorted(topics)) or "none"
                    raise ConfigError(
                        f"{key}.topic", f"topic {spec.topic!r} is not in the bag (topics: {known})"
                    )
                if spec.msgtype is not None and conn.msgtype != spec.msgtype:
                    raise ConfigError(
                        f"{key}.msgtype",
                        f"{spec.topic} carries {conn.msgtype}, expected {spec.msgtype}",
                    )
                self.connections[key] = conn
            # check the fields on the first message of each topic
            for key, conn in self.connections.items():
                first = next(reader.messages(connections=[conn]), None)
                if first is None:
                    raise ConfigError(f"{key}.topic", f"{conn.topic} has no messages")
                try:
                    msg = reader.deserialize(first[2], conn.msgtype)
                except Exception as exc:  # rosbags: unknown type, no stored definition, bad data
                    raise ConfigError(
                        f"{key}.topic",
                        f"{conn.topic}: cannot decode {conn.msgtype} ({type(exc).__name__}: "
                        f"{exc}); a custom type needs its definition stored in the bag",
                    ) from None
                value = self._extract(key, msg, conn.msgtype, first[1] * 1e-9)
                if key == "pose" and m.anemometer.frame == "body" and not math.isfinite(value[1]):
                    raise ConfigError(
                        "anemometer.frame",
                        f"'body' turns the wind by the heading, but pose.field "
                        f"{m.pose.field!r} of {conn.msgtype} is a point without an orientation",
                    )
            self.start_time = reader.start_time
            self.end_time = reader.end_time

    def _open(self) -> Any:
        """An opened reader (use it as a context manager to close it)."""
        try:
            # the constructor already reads the file or folder (a plain file, a folder without
            # metadata.yaml fail here), so it belongs in the guarded part as much as open()
            r = self._reader_cls([self.path], default_typestore=self._typestore)
            r.open()
        except Exception as exc:  # rosbags raises its own error types per format
            raise ConfigError("bag", f"{self.path} is not a readable ROS bag ({exc})") from None
        return _Closing(r)

    # ------------------------------------------------------------------ fields
    def _extract(self, key: str, msg: Any, msgtype: str, t: float) -> Any:
        """The value a topic contributes (message stamped ``t``, s); :class:`ConfigError` naming
        the mapping field on a missing field or a value that is not a finite number."""
        value = self._value(key, msg, msgtype)
        if not np.all(np.isfinite(value[0] if key == "pose" else value)):
            spec = getattr(self.mapping, key)
            fld = "speed" if key == "anemometer" and spec.speed is not None else "field"
            raise ConfigError(
                f"{key}.{fld}",
                f"{spec.topic} at t = {t - self._t_origin:.3f} s: value is not finite ({value})",
            )
        return value

    def _value(self, key: str, msg: Any, msgtype: str) -> Any:
        m = self.mapping
        try:
            if key == "gas":
                v = _resolve(msg, m.gas.field)
                if not _number(v):
                    raise ConfigError("gas.field", f"{msgtype}.{m.gas.field} is not a number")
                return float(v)
            if key == "anemometer":
                w = m.anemometer
                if w.speed is not None or w.direction is not None:
                    if w.speed is None or w.direction is None:
                        raise ConfigError("anemometer.speed", "speed and direction go together")
                    s, a = _resolve(msg, w.speed), _resolve(msg, w.direction)
                    if not (_number(s) and _number(a)):
                        raise ConfigError(
                            "anemometer.speed", f"{msgtype}: speed and direction must be numbers"
                        )
                    a = float(a) + (math.pi if w.direction_is == "from" else 0.0)
                    return np.array([float(s) * math.cos(a), float(s) * math.sin(a), 0.0])
                if w.field is None:
                    raise ConfigError("anemometer.field", "give a vector field or speed/direction")
                return _vector(_resolve(msg, w.field))
            p = _resolve(msg, m.pose.field)
            if hasattr(p, "position") and hasattr(p, "orientation"):
                return _vector(p.position), _yaw(p.orientation)
            return _vector(p), math.nan
        except AttributeError as exc:
            spec = getattr(m, key)
            fld = "field" if key != "anemometer" or spec.speed is None else "speed"
            raise ConfigError(
                f"{key}.{fld}", f"message type {msgtype} has no such field ({exc})"
            ) from None

    # ------------------------------------------------------------------ streaming
    def observations(self) -> Iterator[Observation]:
        """One observation per ``period``, streamed from the bag (module docstring: periods,
        and how each reading is paired with a position)."""
        m = self.mapping
        T = m.period
        names = {c.topic: k for k, c in self.connections.items()}
        poses: list[tuple[float, np.ndarray, float]] = []  # (t, position, heading), recent ones
        wind: np.ndarray | None = None
        last_gas: tuple[float, float] | None = None
        readings: list[tuple[float, float]] = []  # (t, value) of the current period
        pending: list[tuple[int, float, float, np.ndarray]] = []  # (k, t read, value, wind)
        start: float | None = None
        k = 0

        def close_period() -> None:
            nonlocal readings
            if readings:
                t_read, value = _reduce(readings, m.gas.reduce)
            elif m.gas.missing == "hold" and last_gas is not None:
                t_read, value = start + k * T, last_gas[1]
            else:
                t = start + k * T - self._t_origin
                raise ConfigError(
                    "gas.topic",
                    f"{m.gas.topic}: no reading in period {k} ([{t:.3f}, {t + T:.3f}) s); use a "
                    "longer period, or gas.missing: hold to repeat the last reading",
                )
            assert wind is not None
            pending.append((k, t_read, value, wind))
            readings = []

        def ready(final: bool) -> Iterator[Observation]:
            # a period is out once a pose at or after its reading has arrived (or the bag ended)
            while pending and (final or poses[-1][0] >= pending[0][1]):
                kk, t_read, value, w = pending.pop(0)
                pos, heading = _pose_at(poses, t_read)
                yield self._observation(kk, pos, heading, value, w)
            # keep the last pose before the oldest reading still to place, and all after it
            t_need = pending[0][1] if pending else poses[-1][0]
            while len(poses) > 1 and poses[1][0] <= t_need:
                poses.pop(0)

        with self._open() as reader:
            # connections belong to the reader that opened them: select this one's by topic
            conns = [c for c in reader.connections if c.topic in names]
            for conn, stamp, raw in reader.messages(connections=conns):
                t = stamp * 1e-9
                key = names[conn.topic]
                msg = reader.deserialize(raw, conn.msgtype)
                value = self._extract(key, msg, conn.msgtype, t)
                if start is not None:
                    while t >= start + (k + 1) * T - 1e-9:
                        close_period()
                        k += 1
                if key == "gas":
                    last_gas = (t, value)
                    if start is not None:
                        readings.append((t, value))
                elif key == "anemometer":
                    wind = value
                else:
                    # a point pose has no heading: 0 (a body-frame wind is refused for it)
                    poses.append((t, value[0], value[1] if math.isfinite(value[1]) else 0.0))
                if start is None and poses and wind is not None and last_gas is not None:
                    # the first period starts once every topic has spoken
                    start = t
                    if last_gas[0] >= t - 1e-9:
                        readings.append(last_gas)
                if poses and pending:
                    yield from ready(final=False)
        if start is not None and readings:
            close_period()
        if pending:
            yield from ready(final=True)

    def _observation(
        self, k: int, position: np.ndarray, heading: float, gas: float, wind: np.ndarray
    ) -> Observation:
        m = self.mapping
        d = m.dim
        w = wind.copy()
        if m.anemometer.frame == "body":
            c, s = math.cos(heading), math.sin(heading)
            w[:2] = [c * w[0] - s * w[1], s * w[0] + c * w[1]]
        return Observation(
            agent=0,
            t=k * m.period,
            position=position[:d].copy(),
            heading=heading,
            gas=gas,
            detection=bool(gas >= m.gas.threshold),
            wind=w[:d],
        )

    def context(self) -> SearchContext:
        """What an estimator may know: the arena (the mapping's, else the path's extent plus
        ``margin``, 1 m by default), the period, the speed limit and the gas threshold.

        Reads the whole bag once, so that every problem of the data (a value that is not
        finite, a period without a gas reading, a path or a source outside the arena) is
        reported before an estimator runs.
        """
        m = self.mapping
        d = m.dim
        lo = np.full(d, np.inf)
        hi = np.full(d, -np.inf)
        first: Observation | None = None
        outside: Observation | None = None
        box = None
        if m.arena is not None:  # its dimension is checked with the mapping
            box = (np.asarray(m.arena.lower, float), np.asarray(m.arena.upper, float))
        for o in self.observations():
            lo = np.minimum(lo, o.position)
            hi = np.maximum(hi, o.position)
            first = o if first is None else first
            if (
                box is not None
                and outside is None
                and (np.any(o.position < box[0] - 1e-9) or np.any(o.position > box[1] + 1e-9))
            ):
                outside = o
        if first is None:
            raise ConfigError("bag", f"{self.path}: not one full period of data")
        if outside is not None:
            raise ConfigError(
                "arena",
                f"the path leaves it at t = {outside.t:g} s ({np.round(outside.position, 3)} "
                f"outside {m.arena.lower}..{m.arena.upper}): are the units the same?",
            )
        if box is not None:
            arena = Arena(tuple(m.arena.lower), tuple(m.arena.upper), m.arena.resolution)
        else:
            arena = Arena(tuple(lo - m.margin), tuple(hi + m.margin), 0.1)
        for i, src in enumerate(m.sources):
            if not arena.contains(np.asarray(src, float)[None, :])[0]:
                raise ConfigError(f"sources[{i}]", f"{src} lies outside the arena")
        return SearchContext(
            arena=arena,
            dt=m.period,
            agent_ids=(0,),
            start=first.position[None, :],
            speed_limits=np.array([m.max_speed]),
            sensor=SensorInfo("concentration", m.gas.threshold, "reading", False),
            search_region=(tuple(arena.lower[:2]), tuple(arena.upper[:2])),
        )


def _pose_at(poses: list[tuple[float, np.ndarray, float]], t: float) -> tuple[np.ndarray, float]:
    """Position interpolated linearly at ``t`` between the poses around it (held beyond the
    last), and the heading of the nearer pose."""
    i = 0
    while i + 1 < len(poses) and poses[i + 1][0] <= t:
        i += 1
    t0, p0, h0 = poses[i]
    if i + 1 == len(poses) or t <= t0:
        return p0, h0
    t1, p1, h1 = poses[i + 1]
    f = (t - t0) / (t1 - t0)
    return p0 + f * (p1 - p0), (h0 if f <= 0.5 else h1)


class _Closing:
    """Closes an opened rosbags reader on exit (its own ``__enter__`` would open it again)."""

    def __init__(self, reader: Any) -> None:
        self.reader = reader

    def __enter__(self) -> Any:
        return self.reader

    def __exit__(self, *exc: object) -> None:
        self.reader.close()


def _reduce(readings: list[tuple[float, float]], how: str) -> tuple[float, float]:
    """``(stamp, value)`` of one period's ``(stamp, value)`` readings: the last, the largest
    (its stamp) or the mean (the mean stamp)."""
    if how == "mean":
        return (
            float(np.mean([r[0] for r in readings])),
            float(np.mean([r[1] for r in readings])),
        )
    if how == "max":
        return max(readings, key=lambda r: r[1])
    return readings[-1]


def write_bag(
    path: str | Path,
    recording: Any,
    mapping: str | Path | dict[str, Any] | BagMapping,
    *,
    version: Literal[1, 2] = 2,
    gas_rate: int = 1,
    agent: int = 0,
    gas_samples: np.ndarray | None = None,
) -> Path:
    """Write one agent of an odorloc :class:`~odorloc.engine.recorder.Recording` as a bag.

    Topics and fields follow ``mapping`` with standard messages: the gas reading as
    ``std_msgs/Float32`` (its ``field`` must be ``data``), the wind as
    ``geometry_msgs/Vector3Stamped`` (``field: vector``, world frame), the pose as
    ``geometry_msgs/PoseStamped`` (``field: pose``, heading as yaw).

    Parameters
    ----------
    path : str or Path
        ROS 2: a new folder; ROS 1: a ``.bag`` file.
    recording : Recording
    mapping : path, dict or BagMapping
    version : {1, 2}
        ROS 1 or ROS 2 (sqlite3) bag.
    gas_rate : int
        Gas messages per recorded step (the same reading repeated at evenly spread times, as a
        sensor sampling faster than the control period).
    agent : int
        Which agent of the recording.
    gas_samples : (K, gas_rate) ndarray, optional
        The readings within each recorded step, instead of the recorded one repeated (e.g. a
        fast sensor's samples).
    """
    from rosbags.typesys import Stores, get_typestore

    m = load_mapping(mapping)
    if gas_rate < 1:
        raise ConfigError("gas_rate", f"must be >= 1, got {gas_rate}")
    if gas_samples is not None:
        gas_samples = np.asarray(gas_samples, float)
        if gas_samples.shape != (len(recording.t), gas_rate):
            raise ConfigError(
                "gas_samples",
                f"expected shape ({len(recording.t)}, {gas_rate}), got {gas_samples.shape}",
            )
    if m.gas.field != "data" or m.anemometer.field != "vector" or m.pose.field != "pose":
        raise ConfigError("topics", "write_bag writes gas.data, anemometer.vector and pose.pose")
    p = Path(path)
    if version == 1:
        from rosbags.rosbag1 import Writer as W1

        ts = get_typestore(Stores.ROS1_NOETIC)
        writer: Any = W1(p)
        ser = ts.serialize_ros1
    else:
        from rosbags.rosbag2 import Writer as W2

        ts = get_typestore(Stores.ROS2_HUMBLE)
        writer = W2(p, version=9)
        ser = ts.serialize_cdr
    T = ts.types
    Header, Time = T["std_msgs/msg/Header"], T["builtin_interfaces/msg/Time"]
    Float32, Vector3 = T["std_msgs/msg/Float32"], T["geometry_msgs/msg/Vector3"]
    V3S, PS = T["geometry_msgs/msg/Vector3Stamped"], T["geometry_msgs/msg/PoseStamped"]
    Pose, Point, Quat = (
        T["geometry_msgs/msg/Pose"],
        T["geometry_msgs/msg/Point"],
        T["geometry_msgs/msg/Quaternion"],
    )

    def header(ns: int) -> Any:
        stamp = Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)
        return (
            Header(seq=0, stamp=stamp, frame_id="map")
            if version == 1
            else Header(stamp=stamp, frame_id="map")
        )

    base = 1_000_000_000_000  # 1000 s after the epoch: bag times must be positive
    dt = float(np.median(np.diff(recording.t))) if len(recording.t) > 1 else m.period
    if abs(dt - m.period) > 1e-9 * max(dt, 1.0):
        # read back with this mapping, each step would become a different number of periods
        raise ConfigError("period", f"is {m.period} s but the recording's step is {dt:g} s")
    with writer:
        cg = writer.add_connection(m.gas.topic, "std_msgs/msg/Float32", typestore=ts)
        cw = writer.add_connection(
            m.anemometer.topic, "geometry_msgs/msg/Vector3Stamped", typestore=ts
        )
        cp = writer.add_connection(m.pose.topic, "geometry_msgs/msg/PoseStamped", typestore=ts)
        for k, t in enumerate(recording.t):
            ns = base + round(float(t) * 1e9)
            pos = np.zeros(3)
            pos[: recording.positions.shape[2]] = recording.positions[k, agent]
            w = np.zeros(3)
            w[: recording.wind.shape[2]] = recording.wind[k, agent]
            yaw = 0.0
            if k + 1 < len(recording.t):
                step = recording.positions[k + 1, agent, :2] - recording.positions[k, agent, :2]
                if np.hypot(*step) > 1e-12:
                    yaw = math.atan2(step[1], step[0])
            q = Quat(x=0.0, y=0.0, z=math.sin(yaw / 2), w=math.cos(yaw / 2))
            pose = PS(
                header=header(ns),
                pose=Pose(position=Point(x=pos[0], y=pos[1], z=pos[2]), orientation=q),
            )
            writer.write(cp, ns, ser(pose, "geometry_msgs/msg/PoseStamped"))
            wmsg = V3S(header=header(ns), vector=Vector3(x=w[0], y=w[1], z=w[2]))
            writer.write(cw, ns, ser(wmsg, "geometry_msgs/msg/Vector3Stamped"))
            for j in range(gas_rate):
                gns = ns + round(j * dt / gas_rate * 1e9)
                value = recording.gas[k, agent] if gas_samples is None else gas_samples[k, j]
                msg = Float32(data=float(value))
                writer.write(cg, gns, ser(msg, "std_msgs/msg/Float32"))
    return p
