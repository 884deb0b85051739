"""Any searcher carrying a gas map (registry name ``gas-mapping``).

:class:`GasMappingSearcher` wraps a searcher and feeds every reading of the agents it controls
(position, reading, wind, time) into one gas map (registry family ``gas_map``), which is
recorded with the searcher's own beliefs::

    searcher:
      type: gas-mapping
      searcher: {type: rectangular-wave, lane_spacing: 2.0}
      gas_map: {type: kernel-dmv, kernel_width: 0.5, cell_size: 0.25}

The wrapped searcher acts exactly as it would alone: it gets the same observations and the
same random stream, so an episode's path is the same with or without the map. The wrapper
declares what the wrapped searcher supports (dimensions, agent counts), reports its beliefs,
diagnostics and final metrics with the map's added: the map's belief
(:class:`~odorloc.inference.gas_map.base.GasMapBelief`) is recorded as the central belief
(agent ``-1``), its arrays beside those of a central belief of the wrapped searcher in one
snapshot (as a member of a team, each member's map is recorded under its agent); the final
metrics gain ``gas_map_readings`` and the map's highest maximum
(``gas_map_peak_x``, ...).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from odorloc.core import registry
from odorloc.core.errors import ConfigError
from odorloc.core.params import Params
from odorloc.core.registry import ComponentRef, Ref, register
from odorloc.core.types import Action, Observation, SearchContext
from odorloc.inference.estimator import Estimator
from odorloc.inference.gas_map.base import GasMap
from odorloc.models.base import MeasurementModel
from odorloc.searchers.base import Belief, Searcher

__all__ = ["GasMappingParams", "GasMappingSearcher", "MergedBelief"]


class GasMappingParams(Params):
    """Parameters of :class:`GasMappingSearcher`.

    Attributes
    ----------
    searcher : dict
        The wrapped searcher, ``{"type": name, **params}``.
    gas_map : dict
        The gas map, ``{"type": name, **params}`` (family ``gas_map``).
    """

    searcher: Ref("searcher") = ComponentRef(type="random-walk")
    gas_map: Ref("gas_map") = ComponentRef(type="kernel-dmv")


@dataclass(frozen=True, eq=False)
class MergedBelief:
    """Several beliefs of one holder recorded as one snapshot (their keys must differ)."""

    parts: tuple[Any, ...]

    def snapshot(self) -> dict[str, np.ndarray]:
        """The parts' arrays in one dictionary."""
        out: dict[str, np.ndarray] = {}
        for part in self.parts:
            snap = part.snapshot()
            clash = set(out) & set(snap)
            if clash:
                raise RuntimeError(f"two beliefs record the same arrays: {sorted(clash)}")
            out.update(snap)
        return out


_CARRIERS: dict[type, type] = {}


def _carrier(inner: type) -> type:
    """The wrapper class that declares what ``inner`` supports (one per wrapped class)."""
    cls = _CARRIERS.get(inner)
    if cls is None:
        cls = type(
            f"GasMapping{inner.__name__}",
            (GasMappingSearcher,),
            {
                "dims": inner.dims,
                "max_agents": inner.max_agents,
                "min_agents": inner.min_agents,
                "__module__": __name__,
                "__doc__": GasMappingSearcher.__doc__,
            },
        )
        _CARRIERS[inner] = cls
    return cls


@register("searcher", "gas-mapping", GasMappingParams, "any searcher carrying a gas map")
class GasMappingSearcher(Searcher):
    """A searcher that also builds a gas map of its agents' readings (see the module).

    An instance is of a subclass that carries the wrapped searcher's class attributes
    (``dims``, ``max_agents``, ``min_agents``), so that the scenario builder and the teams
    check the wrapped searcher's limits.
    """

    params: GasMappingParams
    dims: ClassVar[tuple[int, ...]] = (2, 3)

    def __new__(cls, params: GasMappingParams | None = None) -> GasMappingSearcher:
        p = params if params is not None else GasMappingParams()
        inner = registry.entry("searcher", p.searcher.type, field="searcher.type").build
        target = _carrier(inner) if isinstance(inner, type) else cls
        return super().__new__(target)

    def __init__(self, params: GasMappingParams | None = None) -> None:
        super().__init__(params if params is not None else GasMappingParams())
        p = self.params
        self.inner: Searcher = p.searcher.build("searcher", field="searcher")
        gm = p.gas_map.build("gas_map", field="gas_map")
        if not isinstance(gm, GasMap):  # pragma: no cover - a plugin registered something else
            raise ConfigError("gas_map.type", f"{p.gas_map.type!r} is not a gas map")
        self.gas_map: GasMap = gm

    def reset(self, ctx: SearchContext, rng: np.random.Generator) -> None:
        super().reset(ctx, rng)
        if ctx.dim not in self.gas_map.dims:
            raise ConfigError("searcher.gas_map.type", f"works in {self.gas_map.dims}D")
        self.inner.reset(ctx, rng)
        # the map's own stream, derived without drawing from (or spawning off) the searcher's
        seq = rng.bit_generator.seed_seq
        child = np.random.SeedSequence(
            seq.entropy, spawn_key=(*seq.spawn_key, 0x6761_736D), pool_size=seq.pool_size
        )
        self.gas_map.reset(ctx, None, np.random.default_rng(child))

    def act(self, observations: Sequence[Observation], rng: np.random.Generator) -> Action:
        action = self.inner.act(observations, rng)
        if observations:
            self.gas_map.update(
                np.array([o.position for o in observations]),
                np.array([o.gas for o in observations]),
                wind=np.array([o.wind for o in observations]),
                t=np.array([o.t for o in observations]),
            )
        return action

    def belief(self) -> Belief | None:
        """The wrapped searcher's belief with the map's beside it (a team member's belief)."""
        inner = self.inner.belief()
        gm = self.gas_map.belief()
        if gm is None or inner is None:
            return gm if inner is None else inner
        return MergedBelief((inner, gm))

    def beliefs(self) -> Mapping[int, Belief]:
        out: dict[int, Any] = dict(self.inner.beliefs())
        gm = self.gas_map.belief()
        if gm is not None:
            out[-1] = gm if -1 not in out else MergedBelief((out[-1], gm))
        return out

    def estimation(self) -> tuple[Estimator, MeasurementModel | None] | None:
        """The wrapped searcher's estimator (an offline replay drives it, not the map)."""
        return self.inner.estimation()

    def diagnostics(self) -> dict[str, float | str]:
        return {**self.inner.diagnostics(), **self.gas_map.diagnostics()}

    def final_metrics(self) -> dict[str, Any]:
        return {**self.inner.final_metrics(), **self.gas_map.final_metrics()}

    def agent_metrics(self) -> dict[int, dict[str, Any]]:
        return self.inner.agent_metrics()
