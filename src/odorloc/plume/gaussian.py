"""Steady Gaussian plume: the model of :mod:`odorloc.models.gaussian` as simulated truth.

The plume follows the current wind at each source (read after every reset and step, so a
slowly turning wind turns the plume) and the sources' current release rates; several sources
superpose. Estimators use :class:`~odorloc.models.gaussian.GaussianPlumeModel`, whose parameters
may differ from the plume's.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from odorloc.core.registry import register
from odorloc.geometry.arena import Arena
from odorloc.models.gaussian import GaussianParams, gaussian_plume
from odorloc.plume.base import PlumeModel
from odorloc.plume.sources import Source
from odorloc.wind.base import WindModel


@register("plume", "gaussian", GaussianParams, "steady Gaussian plume (indoor PF paper), 2D/3D")
class GaussianPlume(PlumeModel):
    """Steady Gaussian plume; follows the current wind at each source and the source rates.

    The downwind direction and speed are read from ``wind.velocity`` at each source position on
    construction/reset and after every step, so a slowly turning wind turns the plume (it stays
    the steady solution for the current wind). Rates are ``source.rate_at(t)``.
    """

    def __init__(
        self,
        params: GaussianParams,
        arena: Arena,
        wind: WindModel,
        sources: Sequence[Source],
    ) -> None:
        super().__init__(arena, wind, sources)
        self.params = params
        self._src = self.source_positions
        self._sync()

    def _sources_changed(self) -> None:
        self._src = self.source_positions
        self._sync()

    def _sync(self) -> None:
        self._winds = self.wind.velocity(self._src)
        self._rates = self.source_rates()

    def _concentration(self, points: np.ndarray) -> np.ndarray:
        return gaussian_plume(
            points, self._src, self._rates, self._winds, self.params, self.arena.lower[-1]
        )

    def frame(self) -> dict[str, np.ndarray]:
        return {
            "model": np.array("gaussian"),
            "src": self._src.copy(),
            "rates": self._rates.copy(),
            "winds": self._winds.copy(),
            "ground": np.array(self.arena.lower[-1]),
            "params": np.array(self.params.model_dump_json()),
        }

    @staticmethod
    def frame_concentration(frame: dict[str, np.ndarray], points: np.ndarray) -> np.ndarray:
        """Concentration at ``(Q, d)`` points from a :meth:`frame`, ``(Q,)``."""
        params = GaussianParams.model_validate_json(str(frame["params"]))
        return gaussian_plume(
            points,
            np.asarray(frame["src"], float),
            np.asarray(frame["rates"], float),
            np.asarray(frame["winds"], float),
            params,
            float(frame["ground"]),
        )
