"""The multi-UAV paper's reference numbers (``shared/papers/muc-osl-multi-uav.txt``)."""

from __future__ import annotations

from odorloc.experiments.reproduction import Citation

#: Table 2: movement of the team over 200 runs (hover time s, turn time s, distance m, E_M kJ).
#: E_M = 0.663 kJ/m * distance + 0.47 kJ/s * hover + 3.415 kJ * turns reproduces both rows, so
#: these are team totals (the three UAVs' times add up to more than the 20-minute limit).
TABLE2 = {
    "col-inf": {"hover_time": 261.0, "turn_time": 223.0, "distance": 893.0, "energy_kj": 1476.27},
    "muc-osl": {"hover_time": 216.0, "turn_time": 190.0, "distance": 907.0, "energy_kj": 1351.71},
}

#: Table 3: numbers exchanged per communication (N particles) and computation complexity.
TABLE3 = {
    "col-inf": {"numbers": "4N", "computation": "O(cN)"},
    "muc-osl": {"numbers": "12", "computation": "O(cN/m)"},
}

#: Movement energy saving of MUC-OSL over Col-Inf (Sect. VI.4.1).
ENERGY_SAVING = 0.0844

#: Success rates at 100 x 200 x 50 m with 3 UAVs (Sect. VI.2.1, Fig. 4): MUC-OSL "only 24 %",
#: Col-Inf "could not accomplish localization task under the energy constraint".
LARGEST_AREA_SUCCESS = {"muc-osl": 0.24, "col-inf": 0.0}

#: Filament (GADEN) world, MUC-OSL (Sect. VI.3, Fig. 9): "about 90 %" success within 8 minutes
#: in 100 x 60 x 30 m, and "more than 80 %" within 8 minutes with more than 3 UAVs.
FILAMENT_SUCCESS_8MIN = 0.90
#: The time, s, at which the paper reads the filament world's success rates (8 minutes).
FILAMENT_AT = 480.0
FILAMENT_SUCCESS_8MIN_MANY_UAVS = 0.80

_NOTE = "our copy starts at its abstract (no title page: authors, venue, year, DOI unknown)"
CITATION = Citation(
    "", "MUC-OSL: multi-UAV collaboration based odor source localization", note=_NOTE
)
"""The paper reproduced."""
