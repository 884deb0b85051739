"""The infotaxis family on the lattice problem as compiled kernels (``lattice-infotaxis``).

OTTO's lattice problem (Loisy & Eloy 2022; the built-in ``lattice-isotropic-*`` scenarios) with
one of the four policies of :mod:`odorloc.planning.lattice_step`: ``infotaxis``,
``space-aware-infotaxis``, ``greedy`` or ``mean-distance``. Each control period the belief over
the grid's cells takes the reading (its hit class, the agent's cell emptied) and the policy
scores the ``2 d`` axis moves, both in one compiled pass each, with the reference's conventions
(masses and entropies floored at ``1e-10``, ties to the lowest move within ``1e-10``). The
belief starts uniform over the cells, before the first reading.

The recipe of the ``infotaxis`` searcher (:mod:`odorloc.searchers.infotaxis`: a grid estimator
and the lattice planner over any measurement model, any grid and any wind) makes the same
choices on the same beliefs up to rounding; this searcher is the lattice problem only (a
``lattice-isotropic`` model on an open lattice) and its arithmetic is that of the kernels, so
its episodes are its own. Without a recording, ``run_episode`` (``odorloc batch``, sweeps)
plays a whole episode of it in one compiled call (:mod:`odorloc.engine.lattice_fused`): the same
episode, step for step, as the engine's loop with this searcher.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, Literal

import numpy as np

from odorloc.core.errors import ConfigError
from odorloc.core.jit import jit
from odorloc.core.params import Params
from odorloc.core.pcg import pcg_double, pcg_poisson_mult
from odorloc.core.registry import ComponentRef, Ref, register
from odorloc.core.types import Action, Command, Observation, SearchContext
from odorloc.geometry.vectors import lattice_moves
from odorloc.inference.belief import GridBelief
from odorloc.models.lattice import IsotropicHitModel, tabulate

# the lattice kernels' compiled passes, called from play()
from odorloc.planning.lattice_step import LatticeKernels, _decide, _move, _observe
from odorloc.searchers.base import Belief, Searcher

__all__ = ["LatticeInfotaxisParams", "LatticeInfotaxisSearcher"]


class LatticeInfotaxisParams(Params):
    """Parameters of :class:`LatticeInfotaxisSearcher`.

    Attributes
    ----------
    model : dict
        The searcher's hit model: ``{type: lattice-isotropic, length, intensity}``.
    policy : str
        ``infotaxis`` (the expected entropy after the move), ``space-aware-infotaxis``,
        ``greedy`` or ``mean-distance`` (:mod:`odorloc.planning.lattice_step`).
    """

    model: Ref("model") = ComponentRef(type="lattice-isotropic")
    policy: Literal["infotaxis", "space-aware-infotaxis", "greedy", "mean-distance"] = "infotaxis"


# ---------------------------------------------------------------------- compiled passes
def play(
    episode: bool,
    hit: int,
    world: np.ndarray,
    sense: np.ndarray,
    cdf_h0: np.ndarray,
    cdf_b0: np.ndarray,
    start: np.ndarray,
    anchor: np.ndarray,
    cell: float,
    enlam: np.ndarray,
    prob: np.ndarray,
    ch: np.ndarray,
    half: np.ndarray,
    dim: int,
    policy: int,
    z: int,
    n_steps: int,
    stuck: int,
    threshold: int,
    b: np.ndarray,
    logb: np.ndarray,
    scores: np.ndarray,
    cells: np.ndarray,
    out: np.ndarray,
) -> int:
    """The searcher's passes, for one reading or for a whole episode of the lattice problem.

    One reading (``episode`` false): the Bayes update of ``b`` / ``logb`` (kernel-shaped, in
    place) with hit class ``hit`` in the cell ``cells[1]``, then the decision; returns the move
    (:func:`~odorloc.geometry.vectors.lattice_moves` order), the entropy into ``out[2]``.

    A whole episode (``episode`` true; :mod:`odorloc.engine.lattice_fused`): the plume's first
    hit class and source cell from the world stream ``world`` (``cdf_h0``, then the row
    ``cdf_b0[h0]``), the agent from ``start``; then, as the engine's loop, the reading and the
    decision, the step cap (``n_steps``), the move, the next hit count from the sensor stream
    ``sense`` (NumPy's Poisson sampler at ``exp(-mean)`` = ``enlam`` of the offset), the reach
    and the stuck rule (``stuck``; -1: none). ``cells`` receives the source cell (row 0), the
    agent's last cell (1) and its cell at the first detection (2); ``out`` the step of the
    first detection (-1: none), the entropy after the first reading and at the end, the
    decisions, the steps and the path length (m: the walker's nodes ``anchor + k cell``).
    Returns the end: 1 reached, 2 the step cap, 3 stuck.

    Both run the update and the decision from one place in this function, so that a reading
    taken alone and one taken in a whole episode give the same numbers to the bit.
    """
    n0, n1, n2 = b.shape
    ag = cells[1]
    prev = start.copy()
    mom = np.empty(3)
    hits = hit
    det = -1
    if episode:
        h0 = np.searchsorted(cdf_h0, pcg_double(world), side="right")
        k = np.searchsorted(cdf_b0[h0], pcg_double(world), side="right")
        src = cells[0]
        src[0] = k // (n1 * n2)
        src[1] = (k // n2) % n1
        src[2] = k % n2
        for c in range(3):
            ag[c] = start[c]
        hits = h0
        if hits >= threshold:
            det = 0
            cells[2] = ag
    src = cells[0]
    back = 0
    steps = 0
    decisions = 0
    path = 0.0
    out[0] = det
    while True:
        ent = _observe(b, logb, ag, prob, ch, half, min(hits, z - 1), mom)
        a = _decide(b, logb, ent, ag, ch, half, dim, policy, scores)
        out[2] = ent
        if not episode:
            return a
        if decisions == 0:
            out[1] = ent
        decisions += 1
        out[3] = decisions
        if steps == n_steps:
            return 2
        # the walker's move, then the next reading (drawn on the source cell too)
        x = _move(ag, a, dim, n0, n1, n2)
        old0, old1, old2 = ag[0], ag[1], ag[2]
        if x[0] >= 0:
            for c in range(3):
                if x[c] != ag[c]:
                    # the walker's node arithmetic: anchor + k cell, k counted from the start
                    path += abs(
                        (anchor[c] + (x[c] - start[c]) * cell)
                        - (anchor[c] + (ag[c] - start[c]) * cell)
                    )
            ag[0] = x[0]
            ag[1] = x[1]
            ag[2] = x[2]
        steps += 1
        out[4] = steps
        out[5] = path
        el = enlam[src[0] - ag[0] + half[0], src[1] - ag[1] + half[1], src[2] - ag[2] + half[2]]
        hits = pcg_poisson_mult(sense, el) if el < 1.0 else 0
        if det < 0 and hits >= threshold:
            det = steps
            out[0] = det
            cells[2] = ag
        if ag[0] == src[0] and ag[1] == src[1] and ag[2] == src[2]:
            return 1
        # the stuck rule: back in the cell of two steps ago
        if steps >= 2:
            if ag[0] == prev[0] and ag[1] == prev[1] and ag[2] == prev[2]:
                back += 1
            else:
                back = 0
        prev[0] = old0
        prev[1] = old1
        prev[2] = old2
        if stuck >= 0 and back > stuck and steps < n_steps:
            return 3


play = jit(play)

_KERNELS: dict[tuple[Any, ...], LatticeKernels] = {}


def _kernels(
    model: IsotropicHitModel, cell: float, shape: tuple[int, ...], policy: str
) -> LatticeKernels:
    """The hit law of ``model`` over a lattice's offsets as kernels (kept for the next
    episodes: tabulating costs more than a short episode)."""
    key = (model.params.model_dump_json(), cell, shape, policy)
    k = _KERNELS.get(key)
    if k is None:
        table = tabulate(model, cell, tuple(n - 1 for n in shape))
        k = _KERNELS[key] = LatticeKernels(table.prob, policy)
        while len(_KERNELS) > 8:
            _KERNELS.pop(next(iter(_KERNELS)))
    return k


@register(
    "searcher",
    "lattice-infotaxis",
    LatticeInfotaxisParams,
    "the infotaxis family on the lattice problem as compiled kernels",
)
class LatticeInfotaxisSearcher(Searcher):
    """One of the four policies on a grid belief, in compiled passes (module docstring)."""

    params: LatticeInfotaxisParams
    max_agents = 1
    declares = False

    def __init__(self, params: LatticeInfotaxisParams | None = None) -> None:
        super().__init__(params or LatticeInfotaxisParams())
        self.model = self.params.model.build("model", field="searcher.model")
        if not isinstance(self.model, IsotropicHitModel):
            raise ConfigError(
                "searcher.model",
                f"must be 'lattice-isotropic', got {self.params.model.type!r}",
            )

    def reset(self, ctx: SearchContext, rng: np.random.Generator) -> None:
        """The hit law over the arena's lattice offsets; the belief waits for the first
        reading."""
        super().reset(ctx, rng)
        arena = ctx.arena
        if arena.occ is not None:
            raise ConfigError("world.arena", "lattice-infotaxis needs an arena without obstacles")
        self.grid = arena.grid
        shape = tuple(int(n) for n in self.grid.shape)
        cell = np.asarray(self.grid.cells, float)
        if not np.all(cell == cell[0]):
            raise ConfigError("world.arena.resolution", "lattice-infotaxis needs square cells")
        self.cell = float(cell[0])
        self.kernels = _kernels(self.model, self.cell, shape, self.params.policy)
        self.moves = lattice_moves(len(shape)) * self.cell
        self.b: np.ndarray | None = None
        self.logb = np.zeros(self.kernels.shape)
        self.entropy = math.nan
        self.entropy_init = math.nan
        self.decisions = 0
        self.last_scores = np.zeros(len(self.moves))
        self._cells = np.zeros((3, 3), np.int64)
        self._out = np.zeros(6)
        # the world's arguments of play(), unused for one reading (of the types it takes)
        self._unused = (
            np.zeros(4, np.uint64), np.zeros(4, np.uint64), np.zeros(1), np.zeros((1, 1)),
            np.zeros(3, np.int64), np.zeros(3), 1.0, np.zeros((1, 1, 1)),
        )  # fmt: skip

    def start_belief(self) -> tuple[np.ndarray, np.ndarray]:
        """The belief before the first reading, uniform over the cells, and its logarithm
        (kernel-shaped)."""
        n = math.prod(self.kernels.shape)
        return np.full(self.kernels.shape, 1.0 / n), np.full(self.kernels.shape, math.log(1.0 / n))

    def act(self, observations: Sequence[Observation], rng: np.random.Generator) -> Action:
        """Take the reading; choose the next move when the last one is done."""
        o = observations[0]
        k = self.kernels
        cell = self.grid.index(np.asarray(o.position, float))[0]
        if self.b is None:
            self.b, self.logb = self.start_belief()
        self._cells[1] = k.agent3(cell)
        a = play(
            False, min(int(o.gas), k.n_classes - 1), *self._unused, k.prob, k.channels, k.half,
            k.dim, k.code, k.n_classes, 0, -1, 1, self.b, self.logb, self.last_scores,
            self._cells, self._out,
        )  # fmt: skip
        self.entropy = float(self._out[2])
        if self.decisions == 0 and math.isnan(self.entropy_init):
            self.entropy_init = self.entropy
        if not o.ready:
            return Action([None])
        self.decisions += 1
        return Action([Command.move(self.moves[a].copy())])

    def adopt(
        self, belief: np.ndarray, entropy_init: float, entropy: float, decisions: int
    ) -> None:
        """The state a whole compiled episode ended in (:mod:`odorloc.engine.lattice_fused`)."""
        self.b = belief
        self.entropy_init = float(entropy_init)
        self.entropy = float(entropy)
        self.decisions = int(decisions)

    def belief(self) -> Belief | None:
        """The belief over the grid's cells (``None`` before the first reading)."""
        if self.b is None:
            return None
        return GridBelief(self.grid, self.b.reshape(self.grid.shape).copy())

    def diagnostics(self) -> dict[str, float | str]:
        """``entropy`` of the belief, bits."""
        return {"entropy": self.entropy}

    def final_metrics(self) -> dict[str, Any]:
        """Entropy (bits) after the first reading and at the end; the decisions taken."""
        return {
            "entropy_init": self.entropy_init,
            "entropy_end": self.entropy,
            "decisions": float(self.decisions),
        }
