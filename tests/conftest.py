"""Shared fixtures (the plain helpers they use live in ``helpers.py``)."""

from __future__ import annotations

import os

import matplotlib
import pytest

from helpers import small_scenario_dict

matplotlib.use("Agg")
os.environ.setdefault("MPLBACKEND", "Agg")


@pytest.fixture
def small_scenario():
    from odorloc.scenarios import Scenario

    return Scenario.from_dict(small_scenario_dict())
