"""Any callable ``observation -> action`` (a trained network, a hand-written rule) as a searcher.

The ``policy`` searcher runs a policy in ``odorloc run``, ``odorloc batch`` sweeps and
reproductions on the same footing as every other searcher: same worlds, same seeds (common
random numbers), same metrics. Its observation and action are those of the Gymnasium and
PettingZoo environments (:mod:`odorloc.searchers.policy_io`), so a policy trained there runs
here unchanged. Every agent of the scenario asks the same policy with its own observation
(parameter sharing); in teams the agents broadcast their readings as the environments do.

The callable is named by import path::

    searcher:
      type: policy
      callable: "mypkg.policies:act"            # act(obs) -> action
      args: {weights: runs/linear.npy}          # optional: mypkg.policies:act(**args) -> policy
      action: {kind: discrete, moves: all}

With ``args`` the callable is a factory called once, when the searcher is built, whose result
is the policy. With ``pass_rng`` the policy is called as ``policy(obs, rng)`` with the episode's
searcher stream, so a stochastic policy is reproducible per seed.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from pydantic import field_validator

from odorloc.core.errors import ConfigError
from odorloc.core.params import Params
from odorloc.core.registry import register
from odorloc.core.types import Action, Command, Declaration, Observation, SearchContext
from odorloc.searchers.base import Searcher
from odorloc.searchers.policy_io import ActionParams, ObservationParams, PolicyIO

__all__ = [
    "LinearPolicy",
    "PolicyParams",
    "PolicySearcher",
    "linear",
    "resolve_callable",
    "upwind_surge",
]


def resolve_callable(ref: str) -> Callable[..., Any]:
    """The object named ``"package.module:attribute"``; :class:`ValueError` naming the problem."""
    mod_name, sep, attr = ref.partition(":")
    if not sep or not mod_name or not attr:
        raise ValueError(f"{ref!r} is not of the form 'package.module:function'")
    try:
        obj: Any = importlib.import_module(mod_name)
        for part in attr.split("."):
            obj = getattr(obj, part)
    except (ImportError, AttributeError) as exc:
        raise ValueError(f"cannot import {ref!r} ({exc})") from None
    if not callable(obj):
        raise ValueError(f"{ref!r} is not callable")
    return obj


class PolicyParams(Params):
    """Parameters of :class:`PolicySearcher`.

    Attributes
    ----------
    callable : str
        Import path of the policy ``obs -> action`` (or of its factory, with ``args``).
    args : dict, optional
        Keyword arguments of the factory; the policy is ``callable(**args)``.
    pass_rng : bool
        Call the policy as ``policy(obs, rng)`` with the searcher's random stream.
    observation : ObservationParams
        The observation vector (as in the environments; give the settings the policy was
        trained with). The default suits the default policy: ``detection, wind, time``.
    action : ActionParams
        The action space (as in the environments).
    """

    callable: str = "odorloc.searchers.policy:upwind_surge"
    args: dict[str, Any] | None = None
    pass_rng: bool = False
    observation: ObservationParams = ObservationParams(
        features=["detection", "wind", "time"], neighbours=False
    )
    action: ActionParams = ActionParams()

    @field_validator("callable")
    @classmethod
    def _importable(cls, v: str) -> str:
        resolve_callable(v)
        return v


@register("searcher", "policy", PolicyParams, "any callable obs -> action (e.g. a trained net)")
class PolicySearcher(Searcher):
    """Asks a policy for each agent's action every control period (see the module docstring)."""

    params: PolicyParams

    def __init__(self, params: PolicyParams | None = None) -> None:
        super().__init__(params or PolicyParams())
        p = self.params
        fn = resolve_callable(p.callable)
        if p.args is not None:
            try:
                fn = fn(**p.args)
            except (TypeError, ValueError, OSError) as exc:
                raise ConfigError("args", f"{p.callable}(**args) failed: {exc}") from None
            if not callable(fn):
                raise ConfigError("args", f"{p.callable}(**args) did not return a callable")
        self.policy: Callable[..., Any] = fn

    def may_declare(self) -> bool:
        """Unless the action space has no declaration (``action.declare: none``)."""
        return self.params.action.declare != "none"

    def reset(self, ctx: SearchContext, rng: np.random.Generator) -> None:
        super().reset(ctx, rng)
        p = self.params
        # The belief estimators get their own stream, spawned so the policy's draws stay put.
        self.io = PolicyIO(ctx, p.observation, p.action, rng.spawn(1)[0])

    def act(self, observations: Sequence[Observation], rng: np.random.Generator) -> Action:
        io = self.io
        io.update_beliefs(observations)
        x = io.encode(observations)
        cmds: list[Command | None] = []
        decls: list[Declaration] = []
        for i, o in enumerate(observations):
            a = self.policy(x[i], rng) if self.params.pass_rng else self.policy(x[i])
            try:
                cmd, decl = io.decode(i, a, o)
            except ValueError as exc:
                raise RuntimeError(f"policy {self.params.callable}: {exc}") from None
            cmds.append(cmd)
            if decl is not None:
                decls.append(decl)
        return Action(cmds, messages=io.broadcasts(observations), declarations=decls)

    def beliefs(self) -> dict[int, Any]:
        out: dict[int, Any] = {}
        for a, est in zip(self.ctx.agent_ids, self.io.estimators, strict=False):
            for b in est.beliefs().values():
                out[a] = b
        return out


def upwind_surge(obs: np.ndarray) -> np.ndarray:
    """A minimal hand-written policy: surge upwind while detecting, else move crosswind,
    alternating sides every 20 s; never declares (the last action component is -1).

    It is the ``policy`` searcher's default (a working example of the interface) and reads the
    searcher's default observation ``detection, wind (d), time``.
    """
    d = len(obs) - 2
    wind = np.asarray(obs[1 : 1 + d], float)
    t = float(obs[-1])
    speed = float(np.linalg.norm(wind))
    up = -wind / speed if speed > 1e-9 else np.eye(d)[0] * -1.0
    if obs[0] > 0.5:
        v = up
    else:
        side = np.zeros(d)
        side[0], side[1] = -up[1], up[0]
        v = side if int(t // 20.0) % 2 == 0 else -side
    return np.concatenate([v, [-1.0]])


class LinearPolicy:
    """A linear policy over a normalised observation: ``z = W [1, (obs - shift) / scale]``.

    ``discrete``: the action is ``argmax z`` (ties to the lowest index); ``velocity``: the action
    is ``tanh z``. A NumPy-only policy to train in the environments and run in sweeps
    (``callable: "odorloc.searchers.policy:linear"``, ``args: {weights: FILE.npz}``).

    Parameters
    ----------
    weights : (A, F + 1) ndarray
    shift, scale : (F,) ndarray
        Observation normalisation (``scale > 0``).
    kind : {"discrete", "velocity"}
    """

    def __init__(
        self, weights: np.ndarray, shift: np.ndarray, scale: np.ndarray, kind: str = "discrete"
    ) -> None:
        w = np.asarray(weights, float)
        sh = np.asarray(shift, float).reshape(-1)
        sc = np.asarray(scale, float).reshape(-1)
        if w.ndim != 2 or w.shape[1] != sh.size + 1 or sc.shape != sh.shape:
            raise ValueError(f"weights {w.shape} do not fit {sh.size} features (+1 bias)")
        if not (np.all(np.isfinite(w)) and np.all(np.isfinite(sh)) and np.all(sc > 0)):
            raise ValueError("weights and shift must be finite and scale > 0")
        if kind not in ("discrete", "velocity"):
            raise ValueError(f"kind must be 'discrete' or 'velocity', got {kind!r}")
        self.weights, self.shift, self.scale, self.kind = w, sh, sc, kind

    def __call__(self, obs: np.ndarray) -> Any:
        x = (np.asarray(obs, float) - self.shift) / self.scale
        z = self.weights[:, 0] + self.weights[:, 1:] @ x
        if self.kind == "discrete":
            return int(np.argmax(z))
        return np.tanh(z)

    def save(self, path: str | Path) -> Path:
        """Write the policy to an ``.npz`` file."""
        p = Path(path)
        np.savez(p, weights=self.weights, shift=self.shift, scale=self.scale, kind=self.kind)
        return p

    @classmethod
    def load(cls, path: str | Path) -> LinearPolicy:
        """Read a policy written by :meth:`save`."""
        try:
            with np.load(path, allow_pickle=False) as z:
                return cls(z["weights"], z["shift"], z["scale"], str(z["kind"]))
        except (OSError, KeyError) as exc:
            raise ValueError(f"cannot read a linear policy from {path} ({exc})") from None


def linear(weights: str) -> LinearPolicy:
    """The :class:`LinearPolicy` saved in ``weights`` (a factory for the ``args`` setting)."""
    return LinearPolicy.load(weights)
