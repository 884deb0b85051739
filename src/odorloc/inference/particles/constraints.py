"""Where particles may be: a constraint on hypotheses (free space of an arena, a box, ...).

A constraint answers :meth:`Constraint.admissible` for ``(Q, d)`` points and can
:meth:`Constraint.project` points back into its bounding box. Filters, resamplers and
initialisers take a constraint rather than an arena, so a belief over something other than
free space (a lattice, a search region) uses the same filter.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np

from odorloc.geometry.arena import Arena

__all__ = ["ArenaConstraint", "Constraint", "place_admissible"]


class Constraint(Protocol):
    """Admissible hypotheses."""

    def admissible(self, points: np.ndarray) -> np.ndarray:
        """``(Q,)`` bool: which of ``(Q, d)`` points are admissible."""
        ...

    def project(self, points: np.ndarray) -> np.ndarray:
        """``(Q, d)`` points clipped into the constraint's bounding box."""
        ...


class ArenaConstraint:
    """Free space of an arena: inside the bounds and not in an obstacle."""

    def __init__(self, arena: Arena) -> None:
        self.arena = arena

    def admissible(self, points: np.ndarray) -> np.ndarray:
        return self.arena.is_free(points)

    def project(self, points: np.ndarray) -> np.ndarray:
        return self.arena.clip(points)


def place_admissible(
    points: np.ndarray, fallback: np.ndarray, constraint: Constraint | None
) -> np.ndarray:
    """Move inadmissible points back: project into the box, then fall back row by row.

    Points outside the bounds are first clipped onto them; points still inadmissible (inside an
    obstacle) take the matching row of ``fallback`` (e.g. the parent particle, assumed
    admissible). ``None`` leaves the points unchanged.
    """
    if constraint is None or len(points) == 0:
        return points
    out = constraint.project(points)
    bad = ~constraint.admissible(out)
    if bad.any():
        out[bad] = fallback[bad]
    return out
