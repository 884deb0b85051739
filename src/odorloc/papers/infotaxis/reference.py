"""OTTO's own results on its isotropic lattice problem (the numbers the infotaxis benchmark
compares with).

Source: OTTO (Loisy & Eloy, "Searching for a source without gradients: how good is infotaxis and
how to beat it", Proc. R. Soc. A 478: 20220118, 2022; code github.com/C0PEP0D/otto v1.0.2, commit
1467029), run with its own evaluator (seed 0) on a 2-core machine of our kind; the problem is
defined in ``shared/otto-pomdp.md`` and built by :mod:`odorloc.papers.infotaxis.lattice`.
Relative standard error <= 1 % for infotaxis, 2 % otherwise. Mean moves count the episodes that
found the source; ``sem`` is its standard error, ``std`` the standard deviation.
"""

from __future__ import annotations

from odorloc.experiments.reproduction import Citation

#: Scenario of each reference setting.
SETTINGS = {
    "2d-l1-i1": {"scenario": "lattice-isotropic-2d", "dim": 2, "length": 1.0, "intensity": 1.0},
    "2d-l2-i2": {"scenario": "lattice-isotropic-2d-l2", "dim": 2, "length": 2.0, "intensity": 2.0},
}

#: (setting, policy) -> OTTO's evaluation.
OTTO = {
    ("2d-l1-i1", "infotaxis"): {
        "episodes": 6400,
        "mean": 13.742,
        "sem": 0.136,
        "std": 17.77,
        "median": 8,
        "p90": 30,
        "p99": 84,
        "p_not_found": 1.9e-4,
    },
    ("2d-l1-i1", "space-aware-infotaxis"): {
        "episodes": 1600,
        "mean": 13.82,
        "sem": 0.27,
        "std": 17.15,
        "median": 8,
        "p90": 30,
        "p99": 84,
        "p_not_found": 4e-7,
    },
    ("2d-l1-i1", "greedy"): {
        "episodes": 1784,
        "mean": 13.87,
        "sem": 0.29,
        "std": 16.51,
        "median": 8,
        "p90": 32,
        "p99": 96,
        "p_not_found": 4.5e-3,
    },
    ("2d-l1-i1", "mean-distance"): {
        "episodes": 10336,
        "mean": 27.5,
        "sem": 0.9,
        "std": 53.0,
        "median": 14,
        "p90": None,
        "p99": None,
        "p_not_found": 0.138,
    },
    ("2d-l2-i2", "infotaxis"): {
        "episodes": 8642,
        "mean": 24.287,
        "sem": 0.234,
        "std": 24.68,
        "median": 17,
        "p90": 51,
        "p99": 121,
        "p_not_found": 3.9e-6,
    },
    ("2d-l2-i2", "space-aware-infotaxis"): {
        "episodes": 2316,
        "mean": 23.81,
        "sem": 0.46,
        "std": 24.66,
        "median": 17,
        "p90": 50,
        "p99": 126,
        "p_not_found": 4e-7,
    },
    ("2d-l2-i2", "greedy"): {
        "episodes": 3400,
        "mean": 78.6,
        "sem": 1.6,
        "std": 95.4,
        "median": 23,
        "p90": 228,
        "p99": None,
        "p_not_found": 2.1e-2,
    },
    ("2d-l2-i2", "mean-distance"): {
        "episodes": 12960,
        "mean": 43.9,
        "sem": 1.3,
        "std": 68.4,
        "median": 34,
        "p90": None,
        "p99": None,
        "p_not_found": 0.218,
    },
}

#: A separate OTTO check with a truly drawn source (4000 episodes), infotaxis.
OTTO_DRAWN_SOURCE = {"2d-l1-i1": (13.71, 0.28), "2d-l2-i2": (24.15, 0.40)}

#: OTTO's time per infotaxis decision, ms, one process on a 2-core shared machine (its
#: environment step adds 0.05-0.06 ms; under heavier load up to 2x longer).
OTTO_DECISION_MS = {"2d-l1-i1": 0.11, "2d-l2-i2": 0.15}

#: Check values of the problem (OTTO's classes): mu(1), P(h | d = 1), P(h0), S(b0 | h0 = 1) in
#: bits, b0 of a neighbour of the centre, the first move's expected entropy decrease (bits).
CHECKS = {
    "2d-l1-i1": {
        "n_grid": 19,
        "n_hits": 3,
        "step_cap": 642,
        "mu1": 0.607409869143,
        "p_hit_d1": (0.5447600431, 0.3308926265, 0.1243473304),
        "p_hit_d2": (0.8484754523, 0.1394165019, 0.01210804581),
        "p_h0": (0.0, 0.8491874051, 0.1508125949),
        "entropy_b0": 5.59872970054,
        "b0_neighbour": 0.0636231026563,
        "first_move_gain": 0.4538995209,
    },
    "2d-l2-i2": {
        "n_grid": 37,
        "n_hits": 4,
        "step_cap": 1283,
        "mu1": 1.33365480976,
        "p_hit_d1": (0.2635124115, 0.351434595, 0.234346219, 0.1507067746),
        "p_h0": (0.0, 0.8081624328, 0.1424753269, 0.04936224032),
        "entropy_b0": 7.58876320501,
        "b0_neighbour": 0.0161084122806,
        "first_move_gain": 0.3164586363,
    },
}

CITATIONS = (
    Citation(
        authors="Vergassola, M.; Villermaux, E.; Shraiman, B. I.",
        title="'Infotaxis' as a strategy for searching without gradients",
        venue="Nature 445, 406-409",
        year=2007,
        doi="10.1038/nature05464",
    ),
    Citation(
        authors="Loisy, A.; Eloy, C.",
        title="Searching for a source without gradients: how good is infotaxis and how to beat it",
        venue="Proceedings of the Royal Society A 478, 20220118",
        year=2022,
        doi="10.1098/rspa.2022.0118",
    ),
)
"""Infotaxis, and the lattice problem (with OTTO, its authors' code) our numbers are held to."""
