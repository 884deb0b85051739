"""odorloc: simulation and benchmarking of mobile-robot odor source localization.

The package is organised by component family::

    world (arena, wind, plume) -> sensors -> searcher -> platform command -> world ...

The documentation (Getting started, Concepts, How-to guides, one page per paper, the Components
reference) is the MkDocs site in the ``docs/`` folder of the source; ``odorloc components NAME``
prints any component's parameters.

Every stochastic call takes an explicit ``numpy.random.Generator``; no global random state is used.
"""

from __future__ import annotations

__version__ = "0.2.0"

__all__ = ["__version__"]
