"""What a learned policy sees and how its answer becomes a command: the encoding shared by the
Gymnasium / PettingZoo environments (:mod:`odorloc.envs`) and the ``policy`` searcher.

One encoding serves both ends, so a policy trained in an environment runs in ``odorloc batch``
sweeps with exactly the inputs it was trained on.

Observation (one flat ``float32`` vector per agent, SI units, in this order; the names are
:attr:`PolicyIO.feature_names`):

========================  =====  =====================================================
feature                   size   meaning
========================  =====  =====================================================
``gas``                   1      gas sensor output (unit of the scenario's sensor)
``detection``             1      1.0 when the reading is at or above the threshold
``wind``                  d      anemometer reading, world frame, m/s
``position``              d      agent position, metres (inside the arena bounds)
``heading``               1      heading, rad in ``[-pi, pi]``
``time``                  1      episode time, seconds
``belief`` (optional)     2d+2   ``valid``, mean (d, m), standard deviation per axis
                                 (d, m), entropy (nats) of a chosen estimator's belief
``neighbours`` (teams)    k(d+3) per other agent of the team, in agent-id order:
                                 ``heard`` (1.0 when its message arrived), its position
                                 relative to this agent (m), its gas reading and detection
========================  =====  =====================================================

The ``neighbours`` block exists in scenarios with several agents: every agent broadcasts its
position and reading each step through the episode's radio, and only neighbours within the
scenario's communication radius receive it (one control period later); slots of agents not
heard are zeros with ``heard = 0``. Unused values are zeros, never NaN.

Actions (:class:`ActionParams`): ``velocity`` is a box ``[-1, 1]^d`` scaled by the platform's
speed limit; ``discrete`` indexes a move set (``axis``: the ``2 d`` lattice moves, ``all``: the
8 (2-D) or 26 (3-D) neighbour directions, plus ``stay``) of ``step`` metres. With ``declare``
the action has one more component (``velocity``: declare when it is > 0) or one more index
(``discrete``: the last one), and the declared position is the agent's own (``position``) or
the belief mean (``belief``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from pydantic import Field, model_validator

from odorloc.core.errors import ConfigError
from odorloc.core.params import Params, Positive
from odorloc.core.registry import ComponentRef, Ref
from odorloc.core.types import (
    Command,
    Declaration,
    Observation,
    Payload,
    SearchContext,
    frozen_array,
)
from odorloc.geometry.vectors import directions_26, lattice_moves
from odorloc.inference.belief import GridBelief, ParticleBelief
from odorloc.inference.estimator import Estimator

__all__ = ["ActionParams", "ObservationParams", "PolicyIO", "ReadingMessage", "belief_summary"]

BASE_FEATURES = ("gas", "detection", "wind", "position", "heading", "time")


@dataclass(frozen=True, eq=False)
class ReadingMessage(Payload):
    """What every agent of a policy-driven team broadcasts each step: its ``position``
    (``(d,)``, metres, a read-only copy), its ``gas`` reading and its ``detection`` (1.0 or
    0.0). A radio sends them as ``d + 2`` float64 numbers: ``8 (d + 2)`` bytes."""

    position: np.ndarray
    gas: float
    detection: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "position", frozen_array(self.position))

    @property
    def nbytes(self) -> int:
        return 8 * (self.position.size + 2)


class ObservationParams(Params):
    """What the observation vector holds (see the module docstring).

    Attributes
    ----------
    features : list of str
        Base features, in the documented order (a subset of ``gas``, ``detection``, ``wind``,
        ``position``, ``heading``, ``time``).
    belief : dict, optional
        A searcher whose estimator runs alongside (``{type: pf-entropy, ...}``: its particle
        filter with its model, :meth:`~odorloc.searchers.base.Searcher.estimation`); the
        belief's mean, spread and entropy are appended.
    neighbours : bool
        In team scenarios, append the neighbours' messages (default ``True``).
    """

    features: list[Literal["gas", "detection", "wind", "position", "heading", "time"]] = Field(
        default_factory=lambda: list(BASE_FEATURES), min_length=1
    )
    belief: Ref("searcher") | None = None
    neighbours: bool = True

    @model_validator(mode="after")
    def _unique(self) -> ObservationParams:
        if len(set(self.features)) != len(self.features):
            raise ValueError("features must not repeat")
        return self


class ActionParams(Params):
    """The action space (see the module docstring).

    Attributes
    ----------
    kind : {"velocity", "discrete"}
    moves : {"axis", "all"}
        Discrete move set: the ``2 d`` lattice moves or every neighbour direction.
    stay : bool
        Discrete: include staying in place.
    step : float, metres, optional
        Discrete move length; default one control period at the platform's top speed.
    declare : {"none", "position", "belief"}
        Whether the action can declare a source, and where (the agent's position or the
        mean of the observation's belief).
    """

    kind: Literal["velocity", "discrete"] = "velocity"
    moves: Literal["axis", "all"] = "axis"
    stay: bool = True
    step: Positive | None = None
    declare: Literal["none", "position", "belief"] = "position"


def belief_summary(belief: Any, dim: int) -> np.ndarray:
    """``valid, mean (d), std (d), entropy`` of a particle or grid belief, ``(2 d + 2,)``.

    A belief of another kind (or none) gives zeros with ``valid = 0``; a 2-D grid in a 3-D world
    fills the horizontal components only.
    """
    out = np.zeros(2 * dim + 2)
    if not isinstance(belief, ParticleBelief | GridBelief):
        return out
    mean = np.asarray(belief.mean, float)
    std = np.sqrt(np.clip(np.diag(np.atleast_2d(belief.cov)), 0.0, None))
    k = min(len(mean), dim)
    vals = np.concatenate([mean[:k], std[:k], [float(belief.entropy)]])
    if not np.all(np.isfinite(vals)):
        return out
    out[0] = 1.0
    out[1 : 1 + k] = mean[:k]
    out[1 + dim : 1 + dim + k] = std[:k]
    out[-1] = vals[-1]
    return out


class PolicyIO:
    """Encodes observations into vectors and decodes policy actions into commands.

    Parameters
    ----------
    ctx : SearchContext
        The context of the agents controlled (all agents of the scenario for a team).
    observation, action : ObservationParams, ActionParams
    rng : numpy.random.Generator
        Stream of the belief estimators (independent of any searcher's own stream).
    time_limit : float, seconds
        Upper bound of the ``time`` feature (``inf`` when unknown).
    """

    def __init__(
        self,
        ctx: SearchContext,
        observation: ObservationParams,
        action: ActionParams,
        rng: np.random.Generator,
        time_limit: float = math.inf,
    ) -> None:
        if action.declare == "belief" and observation.belief is None:
            raise ConfigError("action.declare", "'belief' needs observation.belief (an estimator)")
        self.ctx = ctx
        self.obs_params = observation
        self.act_params = action
        self.dim = d = ctx.dim
        self.n = ctx.n_agents
        self.others = ctx.n_agents_total - 1 if observation.neighbours else 0
        self.time_limit = float(time_limit)
        self._layout: list[tuple[str, int]] = []
        sizes = {"gas": 1, "detection": 1, "wind": d, "position": d, "heading": 1, "time": 1}
        for f in BASE_FEATURES:
            if f in observation.features:
                self._layout.append((f, sizes[f]))
        if observation.belief is not None:
            self._layout.append(("belief", 2 * d + 2))
        if self.others > 0:
            self._layout.append(("neighbours", self.others * (d + 3)))
        self.size = sum(s for _, s in self._layout)
        self.estimators: list[Estimator] = []
        if observation.belief is not None:
            ref: ComponentRef = observation.belief
            for a, child in zip(ctx.agent_ids, rng.spawn(self.n), strict=True):
                parts = ref.build("searcher", field="observation.belief").estimation()
                if parts is None:
                    raise ConfigError(
                        "observation.belief", f"searcher {ref.type!r} composes no estimator"
                    )
                est, model = parts
                est.reset(ctx.subset([a]), model, child)
                self.estimators.append(est)
        self._beliefs = np.zeros((self.n, 2 * d + 2))
        if action.kind == "discrete":
            base = lattice_moves(d) if action.moves == "axis" else _all_directions(d)
            if action.stay:
                base = np.vstack([base, np.zeros((1, d))])
            self.moves = np.asarray(base, float)
        else:
            self.moves = np.zeros((0, d))
        self.can_declare = action.declare != "none"
        self.last_belief_means = np.zeros((self.n, d))
        self._low, self._high = self.observation_bounds()

    # ------------------------------------------------------------------ layout
    @property
    def feature_names(self) -> list[str]:
        """Name of every component of the observation vector."""
        d, ax = self.dim, "xyz"[: self.dim]
        names: list[str] = []
        for f, _ in self._layout:
            if f in ("wind", "position"):
                names += [f"{f}_{c}" for c in ax]
            elif f == "belief":
                names += ["belief_valid", *(f"belief_mean_{c}" for c in ax)]
                names += [*(f"belief_std_{c}" for c in ax), "belief_entropy"]
            elif f == "neighbours":
                for j in range(self.others):
                    names += [f"nb{j}_heard", *(f"nb{j}_rel_{c}" for c in ax)]
                    names += [f"nb{j}_gas", f"nb{j}_detection"]
            else:
                names.append(f)
        assert len(names) == self.size, (names, self.size, d)
        return names

    def observation_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """``(low, high)`` of the observation vector, ``(F,)`` each (``inf`` where unbounded)."""
        lo, hi = self.ctx.arena.lo, self.ctx.arena.hi
        ext = hi - lo
        d = self.dim
        low: list[np.ndarray] = []
        high: list[np.ndarray] = []
        inf = np.inf
        for f, s in self._layout:
            if f in ("gas", "wind"):
                low.append(np.full(s, -inf))
                high.append(np.full(s, inf))
            elif f == "detection":
                low.append(np.zeros(1))
                high.append(np.ones(1))
            elif f == "position":
                low.append(lo.copy())
                high.append(hi.copy())
            elif f == "heading":
                low.append(np.array([-math.pi]))
                high.append(np.array([math.pi]))
            elif f == "time":
                low.append(np.zeros(1))
                high.append(np.array([self.time_limit]))
            elif f == "belief":
                low.append(np.concatenate([[0.0], lo, np.zeros(d), [-inf]]))
                high.append(np.concatenate([[1.0], hi, np.full(d, inf), [inf]]))
            else:
                one_lo = np.concatenate([[0.0], -ext, [-inf, 0.0]])
                one_hi = np.concatenate([[1.0], ext, [inf, 1.0]])
                low.append(np.tile(one_lo, self.others))
                high.append(np.tile(one_hi, self.others))
        return (
            np.concatenate(low).astype(np.float32),
            np.concatenate(high).astype(np.float32),
        )

    @property
    def n_discrete(self) -> int:
        """Number of discrete actions (moves, plus one to declare)."""
        return len(self.moves) + int(self.can_declare)

    @property
    def action_size(self) -> int:
        """Length of a ``velocity`` action vector."""
        return self.dim + int(self.can_declare)

    # ------------------------------------------------------------------ encoding
    def update_beliefs(self, observations: Sequence[Observation]) -> None:
        """Feed this step's observations to the belief estimators."""
        for i, est in enumerate(self.estimators):
            est.update(observations[i])
            self._beliefs[i] = belief_summary(est.belief(), self.dim)
            if self._beliefs[i, 0] > 0:
                self.last_belief_means[i] = self._beliefs[i, 1 : 1 + self.dim]
            else:
                self.last_belief_means[i] = observations[i].position

    def encode(self, observations: Sequence[Observation]) -> np.ndarray:
        """Observation vectors of the controlled agents, ``(n_agents, F)`` float32.

        Call :meth:`update_beliefs` first when the observation carries a belief.
        """
        d = self.dim
        out = np.zeros((len(observations), self.size))
        for i, o in enumerate(observations):
            row = out[i]
            c = 0
            for f, s in self._layout:
                if f == "gas":
                    row[c] = o.gas
                elif f == "detection":
                    row[c] = 1.0 if o.detection else 0.0
                elif f == "wind":
                    row[c : c + d] = o.wind[:d]
                elif f == "position":
                    row[c : c + d] = o.position
                elif f == "heading":
                    row[c] = o.heading
                elif f == "time":
                    row[c] = o.t
                elif f == "belief":
                    row[c : c + s] = self._beliefs[i]
                else:
                    self._neighbours(o, row[c : c + s])
                c += s
        # Bounded values stay inside their bounds, float32 rounding included.
        v = out.astype(np.float32)
        np.minimum(v, self._high, out=v)
        np.maximum(v, self._low, out=v)
        return v

    def _neighbours(self, o: Observation, block: np.ndarray) -> None:
        d = self.dim
        w = d + 3
        me = o.agent
        for m in o.messages:
            s = int(m.sender)
            if s == me:
                continue
            j = s if s < me else s - 1  # slots follow agent ids, skipping oneself
            if not 0 <= j < self.others:
                continue
            p = m.payload
            row = block[j * w : (j + 1) * w]
            row[0] = 1.0
            if isinstance(p, ReadingMessage):
                row[1 : 1 + d] = p.position[:d] - o.position[:d]
                row[1 + d] = p.gas
                row[2 + d] = p.detection
            else:  # a dict-like payload with the same names
                row[1 : 1 + d] = np.asarray(p["position"], float)[:d] - o.position[:d]
                row[1 + d] = float(np.asarray(p["gas"]).reshape(-1)[0])
                row[2 + d] = float(np.asarray(p["detection"]).reshape(-1)[0])

    def broadcasts(self, observations: Sequence[Observation]) -> dict[int, ReadingMessage]:
        """The message every agent sends this step (position and reading), by agent id."""
        if self.others == 0:
            return {}
        return {
            o.agent: ReadingMessage(o.position, float(o.gas), 1.0 if o.detection else 0.0)
            for o in observations
        }

    # ------------------------------------------------------------------ decoding
    def decode_many(
        self, actions: dict[int, Any], observations: Sequence[Observation]
    ) -> tuple[dict[int, Command], list[Declaration]]:
        """:meth:`decode` for several agents (agent index -> action): the commands by agent and
        the declarations in agent order. Velocity actions of one shape are checked, clipped and
        scaled as one array (the same numbers as one by one)."""
        keys = list(actions)
        if self.act_params.kind != "discrete" and len(keys) > 1:
            try:
                a = np.asarray([actions[k] for k in keys], float)
            except (TypeError, ValueError):
                a = None
            if a is not None and a.shape == (len(keys), self.action_size) and np.isfinite(a).all():
                v = np.minimum(np.maximum(a[:, : self.dim], -1.0), 1.0)
                v *= np.asarray(self.ctx.speed_limits, float)[keys, None]
                cmds = {k: Command("velocity", v[j]) for j, k in enumerate(keys)}
                decls = []
                if self.can_declare:
                    for j, k in enumerate(keys):
                        if a[j, -1] > 0.0:
                            decls.append(self._declaration(k, observations[k]))
                return cmds, decls
        cmds = {}
        decls = []
        for k in keys:
            cmd, decl = self.decode(k, actions[k], observations[k])
            cmds[k] = cmd
            if decl is not None:
                decls.append(decl)
        return cmds, decls

    def _declaration(self, i: int, o: Observation) -> Declaration:
        """Agent ``i``'s declaration: its own position or its belief mean (``declare``)."""
        where = o.position if self.act_params.declare == "position" else self.last_belief_means[i]
        return Declaration(np.asarray(where, float)[None, :], agent=o.agent)

    def decode(self, i: int, action: Any, o: Observation) -> tuple[Command, Declaration | None]:
        """The command (and declaration) of controlled agent ``i`` for a policy's ``action``.

        Raises :class:`ValueError` naming what is wrong with an action outside the space.
        """
        p = self.act_params
        vmax = float(self.ctx.speed_limits[i])
        declare = False
        if p.kind == "discrete":
            a = np.asarray(action).reshape(-1)
            if a.size != 1 or not (
                np.issubdtype(a.dtype, np.integer)
                or (np.issubdtype(a.dtype, np.floating) and float(a[0]).is_integer())
            ):
                raise ValueError(f"a discrete action must be one integer, got {action!r}")
            k = int(a[0])
            if not 0 <= k < self.n_discrete:
                raise ValueError(f"discrete action {k} is outside [0, {self.n_discrete})")
            if self.can_declare and k == self.n_discrete - 1:
                cmd = Command.hold()
                declare = True
            else:
                step = p.step if p.step is not None else vmax * self.ctx.dt
                mv = self.moves[k]
                cmd = Command.hold() if not mv.any() else Command.move(mv * step)
        else:
            a = np.asarray(action, float).reshape(-1)
            if a.shape != (self.action_size,) or not np.isfinite(a).all():
                raise ValueError(
                    f"a velocity action must be {self.action_size} finite numbers, got {action!r}"
                )
            # np.clip's dispatch costs more than the arithmetic on d numbers
            v = np.minimum(np.maximum(a[: self.dim], -1.0), 1.0)
            v *= vmax
            cmd = Command("velocity", v)
            declare = self.can_declare and a[-1] > 0.0
        return cmd, self._declaration(i, o) if declare else None


def _all_directions(dim: int) -> np.ndarray:
    if dim == 3:
        return np.asarray(directions_26(), float)
    a = np.arange(8) * (math.pi / 4.0)
    return np.column_stack([np.cos(a), np.sin(a)])
