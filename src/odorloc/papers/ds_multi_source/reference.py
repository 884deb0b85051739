"""The D-S multi-source mapping paper's numbers (``shared/papers/ds-multi-source-mapping.txt``)."""

from __future__ import annotations

from odorloc.experiments.reproduction import Citation

#: Sections 4.2-4.3: mission time (s), distance (m), residual uncertainty sum of X.
PAPER = {
    "ds-mapping": {"time": 2500.0, "distance": 496.1, "residual": 157.1, "source": "Sec. 4.3"},
    "ds-rectangular-wave": {
        "time": 4283.5,
        "distance": 1060.8,
        "residual": 254.1,
        "source": "Sec. 4.2 (5 rounds)",
    },
}

#: Scenes of Figs. 1-2: (time s, distance m, residual uncertainty).
SCENES = {
    "ds-rectangular-wave": [
        (781.5, 193.5, 1089.0),
        (2532.5, 627.1, 374.6),
        (4283.5, 1060.8, 254.1),
    ],
    "ds-mapping": [(400.0, 97.4, 1317.4), (800.0, 183.8, 683.0), (2500.0, 496.1, 157.1)],
}

#: Paired ratios dynamic / wave the paper's numbers give (time, distance, residual).
RATIOS = {"time": 2500.0 / 4283.5, "distance": 496.1 / 1060.8, "residual": 157.1 / 254.1}

CITATION = Citation(
    authors="Li, J.-G.; Zhou, J.-Y.; Yang, J.; Liu, J.; Zeng, F.-L.; Yang, L.",
    title=(
        "Localizing Multiple Odor Sources with a Mobile Robot in Time-varying Airflow "
        "Environments using Dempster-Shafer Inference"
    ),
    note="conference paper; our copy gives neither its venue, year nor DOI",
)
"""The paper reproduced (Tianjin University of Technology and Education)."""

ODOR_PATH_CITATION = Citation(
    authors="Li, J.-G.; Meng, Q.-H.; Li, F.; Zhang, M.-L.",
    title="Mobile Robot based Odor Path Estimation via Dynamic Window Approach",
    note="conference paper; our copy gives neither its venue, year nor DOI",
)
"""The odor-path paper whose air-mass path maps (eqs. 4, 11-12) the D-S map reads."""
