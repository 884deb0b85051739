"""odorloc: simulation and benchmarking of mobile-robot odor source localization.

The package is organised by component family (see ``DESIGN`` in the docs)::

    world (arena, wind, plume) -> sensors -> searcher -> platform command -> world ...

Every stochastic call takes an explicit ``numpy.random.Generator``; no global random state is used.
"""

from __future__ import annotations

__version__ = "0.1.0"

__all__ = ["__version__"]
