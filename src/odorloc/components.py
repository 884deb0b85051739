"""Imports every component module so that each registers itself in :mod:`odorloc.registry`."""

from __future__ import annotations

import importlib

_MODULES = [
    "odorloc.wind.uniform",
    "odorloc.wind.meander",
    "odorloc.wind.farrell",
    "odorloc.wind.potential",
    "odorloc.plume.filament",
    "odorloc.plume.gaussian",
    "odorloc.plume.vergassola",
    "odorloc.plume.eulerian",
    "odorloc.plume.replay",
    "odorloc.sensors.gas",
    "odorloc.sensors.encounter",
    "odorloc.sensors.anemometer",
    "odorloc.inference.resampling",
    "odorloc.platforms.wheeled",
    "odorloc.platforms.uav",
    "odorloc.searchers.simple",
    "odorloc.searchers.pf_entropy",
    "odorloc.searchers.gradient_bionic",
    "odorloc.searchers.ds_mapping",
    "odorloc.searchers.team",
]

for _name in _MODULES:
    importlib.import_module(_name)
