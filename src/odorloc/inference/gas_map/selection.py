"""Parameters chosen by the NLPD of held-out readings (cross-validation).

Lilienthal et al. (2009) learn Kernel DM+V's kernel width by minimising the average negative log
predictive density of readings left out of the map (NLPD, their eq. 8). :func:`select_parameters`
does that for any member and any of its parameters, the cell size included: for each
combination of the candidate values, the readings are split into ``folds`` folds of whole
stretches of the path (:func:`~odorloc.inference.gas_map.readings.time_blocks`), a map is built
from all folds but one and scored on the one left out, in turn; the combination with the lowest
NLPD over all held-out readings wins (ties: the first in the order the candidates are given).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from odorloc.core.errors import ConfigError
from odorloc.geometry.grid import CellGrid
from odorloc.inference.gas_map.base import GasMap, build_gas_map, nlpd
from odorloc.inference.gas_map.readings import Readings, time_blocks

__all__ = ["Selection", "select_parameters"]


@dataclass(frozen=True)
class Selection:
    """What :func:`select_parameters` chose and why.

    Attributes
    ----------
    best : dict
        The winning candidate values.
    scores : list of (dict, float)
        Every combination tried with its NLPD, in the order tried.
    """

    best: dict[str, Any]
    scores: list[tuple[dict[str, Any], float]]


def select_parameters(
    name: str,
    readings: Readings,
    grid_for: Callable[[float], CellGrid],
    candidates: Mapping[str, Sequence[Any]],
    params: Mapping[str, Any] | None = None,
    folds: int = 5,
    block: float = 10.0,
    arena: Any = None,
) -> Selection:
    """Choose a member's parameters by cross-validated NLPD (see the module docstring).

    Parameters
    ----------
    name : str
        Registry name of the gas map (``kernel-dmv``, ...).
    readings : Readings
        All readings (each fold holds out some of them).
    grid_for : callable
        ``grid_for(cell_size) -> CellGrid``: the grid of a candidate cell size.
    candidates : dict of str to sequence
        Values to try per parameter (``{"kernel_width": [0.1, 0.2, 0.4]}``); ``cell_size``
        changes the grid.
    params : dict, optional
        The member's other parameters.
    folds : int
        Number of folds, >= 2.
    block : float, seconds
        Length of the path stretches that go to one fold.
    arena : Arena, optional
        Obstacles and bounds of the maps.

    Raises
    ------
    ConfigError
        Naming ``candidates`` (no values, or a parameter the member does not have) or
        ``readings`` (a fold without readings: too few readings for the folds).
    """
    base = dict(params or {})
    if not candidates or any(len(list(v)) == 0 for v in candidates.values()):
        raise ConfigError("candidates", "need at least one value per parameter")
    fold = time_blocks(readings, block, folds)
    if len(np.unique(fold)) < folds:
        raise ConfigError(
            "readings", f"{len(readings)} readings do not fill {folds} folds of {block:g} s"
        )
    keys = list(candidates)
    scores: list[tuple[dict[str, Any], float]] = []
    for combo in itertools.product(*(list(candidates[k]) for k in keys)):
        values = dict(zip(keys, combo, strict=True))
        settings = {**base, **values}
        cell = float(_build(name, settings).params.cell_size)  # given, or the member's default
        grid = grid_for(cell)
        means, variances, held = [], [], []
        for k in range(folds):
            gm = _build(name, settings)
            gm.start(grid, arena)
            gm.update(*_arrays(readings.subset(fold != k)))
            test = readings.subset(fold == k)
            m, v = gm.predict(test.positions)
            means.append(m)
            variances.append(v)
            held.append(test.values)
        score = nlpd(np.concatenate(means), np.concatenate(variances), np.concatenate(held))
        scores.append((values, score))
    finite = [(v, s) for v, s in scores if math.isfinite(s)]
    best = min(finite, key=lambda vs: vs[1])[0] if finite else scores[0][0]
    return Selection(dict(best), scores)


def _build(name: str, settings: Mapping[str, Any]) -> GasMap:
    try:
        return build_gas_map(name, **settings)
    except ConfigError as exc:
        raise ConfigError(f"candidates.{exc.field}", exc.problem) from None


def _arrays(r: Readings) -> tuple[Any, ...]:
    return r.positions, r.values, r.wind, r.t if r.has_times else None
