"""A plume of one's own (the how-to guide "Write a plume")."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from odorloc.core.params import Params, Positive
from odorloc.core.registry import register
from odorloc.geometry.arena import Arena
from odorloc.plume.base import PlumeModel
from odorloc.plume.sources import Source
from odorloc.wind.base import WindModel


class WedgePlumeParams(Params):
    """Parameters of :class:`WedgePlume`.

    Attributes
    ----------
    sigma0 : float, metres
        Crosswind width of the plume at the source.
    spread : float
        Growth of the width per metre downwind (the wedge's half-angle, as a slope).
    """

    sigma0: Positive = 0.1
    spread: Positive = 0.2


def wedge(
    points: np.ndarray,
    sources: np.ndarray,
    winds: np.ndarray,
    rates: np.ndarray,
    params: WedgePlumeParams,
) -> np.ndarray:
    """Concentration of wedges at ``(Q, d)`` points, ``(Q,)``, from sources ``(S, d)`` with the
    wind ``(S, d)`` m/s at each and their release rates ``(S,)``."""
    c = np.zeros(len(points))
    for s, u, q in zip(sources, winds, rates, strict=True):
        speed = float(np.linalg.norm(u))
        if speed == 0.0:
            continue
        rel = points - s
        down = rel @ (u / speed)  # metres downwind of the source
        across = np.linalg.norm(rel - down[:, None] * (u / speed), axis=1)
        width = params.sigma0 + params.spread * np.maximum(down, 0.0)
        norm = q / (speed * (np.sqrt(2.0 * np.pi) * width) ** (points.shape[1] - 1))
        c += np.where(down >= 0.0, norm * np.exp(-0.5 * (across / width) ** 2), 0.0)
    return c


@register("plume", "wedge", WedgePlumeParams, "steady wedge of odor downwind of each source")
class WedgePlume(PlumeModel):
    """A steady wedge downwind of each source: Gaussian across the wind, widening linearly
    downwind, the same total flux at every distance; nothing upwind. It follows the current
    wind at each source and the sources' current release rates."""

    Params = WedgePlumeParams

    def __init__(
        self, params: WedgePlumeParams, arena: Arena, wind: WindModel, sources: Sequence[Source]
    ) -> None:
        super().__init__(arena, wind, sources)
        self.params = params
        self._sync()

    def _sync(self) -> None:
        # called after every reset and step: the wind at the sources and their rates
        src = self.source_positions
        self._src, self._wind, self._rates = src, self.wind.velocity(src), self.source_rates()

    def _concentration(self, points: np.ndarray) -> np.ndarray:
        return wedge(points, self._src, self._wind, self._rates, self.params)

    def frame(self) -> dict[str, np.ndarray]:
        """What reproduces the field: a recorded movie replays it (``frame_concentration``)."""
        return {
            "model": np.array("wedge"),
            "src": self._src.copy(),
            "wind": self._wind.copy(),
            "rates": self._rates.copy(),
            "params": np.array(self.params.model_dump_json()),
        }

    @staticmethod
    def frame_concentration(frame: dict[str, np.ndarray], points: np.ndarray) -> np.ndarray:
        params = WedgePlumeParams.model_validate_json(str(frame["params"]))
        return wedge(points, frame["src"], frame["wind"], frame["rates"], params)
