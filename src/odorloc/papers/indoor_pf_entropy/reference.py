"""The indoor PF paper's reference numbers (``shared/papers/indoor-pf-entropy.txt``)."""

from __future__ import annotations

from odorloc.experiments.reproduction import Citation

#: Table 1 (simulation): start index -> start point, mean search time (s), success rate, runs.
TABLE1 = {
    2: {"start": (2.15, 3.60), "mean_time": 110.0, "success_rate": 0.94, "n": 50},
    4: {"start": (2.40, 4.55), "mean_time": 120.0, "success_rate": 0.90, "n": 50},
}

#: Real-robot Tables 4/5: mean search time (s), PF + entropy vs gradient-bionic hybrid.
REAL_ROBOT = {"pf-entropy": (172.8, 185.4), "gradient-bionic": (255.6, 266.0)}

#: Success criterion: estimate within this distance of the source (m).
SUCCESS_RADIUS = 0.5

CITATION = Citation(
    authors="Ye, X.; Guo, B.; Gu, Y.; Jiu, H.; Pang, S.",
    title=(
        "An Efficient Odor Source Localization Method for Wheeled Mobile Robots in Indoor "
        "Ventilated Environments"
    ),
    venue="Technologies 14(5), 279",
    year=2026,
    doi="10.3390/technologies14050279",
)
"""The paper reproduced."""
