"""Gas distribution maps (registry family ``gas_map``): concentration maps built from readings.

- :mod:`.base`: the :class:`~odorloc.inference.gas_map.base.GasMap` base class on the
  estimator seam, its belief, the map maxima and the NLPD;
- :mod:`.readings`: readings as checked arrays, and their split into folds;
- :mod:`.kernels`: kernel sums of readings onto cells (compiled loop with a NumPy reference);
- :mod:`.kernel_dmv`: Kernel DM+V, Kernel DM+V/W and TD Kernel DM+V;
- :mod:`.gmrf`: the GMRF gas map with obstacles and time-variant readings;
- :mod:`.selection`: kernel width, cell size or any other parameter chosen by the NLPD of
  held-out readings (cross-validation).
"""

from odorloc.inference.gas_map.base import (
    GasMap,
    GasMapBelief,
    GasMapParams,
    build_gas_map,
    map_grid,
    map_maxima,
    nlpd,
)
from odorloc.inference.gas_map.gmrf import GMRFGasMap, GMRFParams
from odorloc.inference.gas_map.kernel_dmv import (
    KernelDMV,
    KernelDMVParams,
    KernelDMVW,
    KernelDMVWParams,
    TDKernelDMV,
    TDKernelDMVParams,
)
from odorloc.inference.gas_map.readings import Readings, as_readings, time_blocks

__all__ = [
    "GMRFGasMap",
    "GMRFParams",
    "GasMap",
    "GasMapBelief",
    "GasMapParams",
    "KernelDMV",
    "KernelDMVParams",
    "KernelDMVW",
    "KernelDMVWParams",
    "Readings",
    "TDKernelDMV",
    "TDKernelDMVParams",
    "as_readings",
    "build_gas_map",
    "map_grid",
    "map_maxima",
    "nlpd",
    "time_blocks",
]
