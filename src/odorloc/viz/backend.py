"""pyplot on demand: the drawing functions import it when they draw, never at module import.

Importing pyplot starts a GUI backend and global figure state; a process that only simulates
(a sweep worker, a registry lookup) should pay neither. Every function that draws calls
:func:`pyplot` first.
"""

from __future__ import annotations

import sys
from types import ModuleType

__all__ = ["pyplot"]


def pyplot() -> ModuleType:
    """``matplotlib.pyplot``, on the file-writing ``Agg`` backend unless pyplot was already
    imported with another backend (a notebook's inline backend is then kept)."""
    if "matplotlib.pyplot" not in sys.modules:
        import matplotlib

        matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt
