"""Odor-path (air-mass path) probability maps by the dynamic-window method (odor-path paper).

- :mod:`.estimator`: :class:`~odorloc.inference.odor_path.estimator.OdorPathEstimator`, the
  sub-dynamic windows and the path map as a sparse patch;
- :mod:`.kernel`: the per-window loop, compiled with numba when available.
"""

from __future__ import annotations

from odorloc.geometry.grid import CellGrid
from odorloc.inference.odor_path.estimator import (
    DenseCanvas,
    OdorPathEstimator,
    OdorPathParams,
    PathPatch,
    SubWindow,
    from_paper_k,
    paper_k,
)
from odorloc.inference.odor_path.kernel import HAVE_NUMBA

__all__ = [
    "HAVE_NUMBA",
    "CellGrid",
    "DenseCanvas",
    "OdorPathEstimator",
    "OdorPathParams",
    "PathPatch",
    "SubWindow",
    "from_paper_k",
    "paper_k",
]
