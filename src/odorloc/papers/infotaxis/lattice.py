"""Scenarios of OTTO's isotropic lattice problem for any dimension and parameters.

:func:`lattice_scenario` builds the scenario with OTTO's automatic choices (Loisy & Eloy 2022,
the OTTO package): the number of hit classes ``ceil(mu(dx) + sqrt(mu(dx))) + 1``, the grid size
``N`` (:func:`~odorloc.models.lattice.auto_grid_size`) and the step cap
(:func:`~odorloc.models.lattice.auto_step_cap`); cells of 1 m, one move per 1 s step, the agent at
the centre cell, the first hit then the source drawn by the plume (``start: initial-hit``), the
end on the source cell (``reach_radius`` half a cell) and the stuck rule (``stuck_limit: 8``).
The built-in ``lattice-isotropic-*`` files are its output.
"""

from __future__ import annotations

import math
from typing import Any

from odorloc.core.errors import ConfigError
from odorloc.models.lattice import auto_grid_size, auto_n_hits, auto_step_cap

__all__ = ["STUCK_LIMIT", "lattice_problem", "lattice_scenario"]

#: OTTO's stuck rule: more than 8 back-and-forth moves in a row end the search.
STUCK_LIMIT = 8


def lattice_problem(dim: int, length: float, intensity: float) -> dict[str, int]:
    """OTTO's automatic ``n_hits``, grid size ``N`` and step cap for ``lambda/dx = length``,
    ``R dt = intensity`` (cells of 1 m)."""
    if isinstance(dim, bool) or not isinstance(dim, int) or dim not in (2, 3):
        raise ConfigError("dim", f"must be the integer 2 or 3, got {dim!r}")
    if not (math.isfinite(length) and length >= 1.0):
        raise ConfigError("length", f"lambda/dx must be a finite number >= 1, got {length}")
    if not (math.isfinite(intensity) and intensity > 0):
        raise ConfigError("intensity", f"R dt must be a finite number > 0, got {intensity}")
    z = auto_n_hits(length, intensity, 1.0, dim)
    n = auto_grid_size(length, intensity, 1.0, dim, z)
    return {"n_hits": z, "grid": n, "step_cap": auto_step_cap(length, intensity, 1.0, dim, n)}


def lattice_scenario(
    dim: int,
    length: float,
    intensity: float,
    name: str | None = None,
    searcher: dict[str, Any] | None = None,
) -> dict[str, Any]:
    """The scenario (as a plain dict, ready for YAML) of the lattice problem.

    Parameters
    ----------
    dim : {2, 3}
    length : float
        ``lambda / dx``.
    intensity : float
        ``R dt``.
    name : str, optional
    searcher : dict, optional
        Default: infotaxis with the problem's own model.
    """
    pr = lattice_problem(dim, length, intensity)
    n = pr["grid"]
    centre = [n // 2 + 0.5] * dim
    model = {"type": "lattice-isotropic", "length": float(length), "intensity": float(intensity)}
    tag = f"{dim}d" if (length, intensity) == (1.0, 1.0) else f"{dim}d-l{length:g}-i{intensity:g}"
    return {
        "name": name or f"lattice-isotropic-{tag}",
        "description": (
            f"OTTO's isotropic lattice problem, {dim}-D, lambda/dx = {length:g}, R dt = "
            f"{intensity:g}: {n}^{dim} cells, first hit, {pr['step_cap']}-step cap"
        ),
        "paper": "infotaxis",
        "world": {
            "arena": {"lower": [0.0] * dim, "upper": [float(n)] * dim, "resolution": 1.0},
            "sources": [{"position": list(centre), "rate": float(intensity)}],
            "wind": {"type": "uniform", "velocity": [0.0] * dim},
            "plume": {"type": "lattice-isotropic", "length": float(length), "start": "initial-hit"},
            "dt": 1.0,
        },
        "sensors": {"gas": {"type": "encounter"}, "anemometer": {"type": "anemometer"}},
        "platform": {"type": "lattice"},
        "agents": {"starts": [list(centre)]},
        "searcher": searcher or {"type": "infotaxis", "model": model},
        "task": {"end": "reach", "reach_radius": 0.5, "stuck_limit": STUCK_LIMIT},
        "limits": {"control_dt": 1.0, "time": float(pr["step_cap"])},
        "seed": 0,
        "recording": {"plume_grid": 1.0, "plume_stride": 1000, "belief_stride": 1},
    }
