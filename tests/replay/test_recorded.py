"""A recording fed back as observations."""

from __future__ import annotations

import numpy as np
import pytest

from helpers import small_scenario_dict
from odorloc.core.errors import ConfigError
from odorloc.engine.episode import run_episode
from odorloc.replay.recorded import recording_observations
from odorloc.scenarios import Scenario


def test_observations_of_a_recording_are_its_rows() -> None:
    sc = Scenario.from_dict(small_scenario_dict("zigzag"))
    res = run_episode(sc, 1, 2, record=True)
    rec = res.recording
    assert rec is not None
    obs = list(recording_observations(rec, 0, 3))
    assert len(obs) == len(range(0, len(rec.t), 3))
    for o, k in zip(obs, range(0, len(rec.t), 3), strict=True):
        assert o.t == rec.t[k] and o.gas == rec.gas[k, 0] and o.detection == rec.detection[k, 0]
        np.testing.assert_array_equal(o.position, rec.positions[k, 0])
        np.testing.assert_array_equal(o.wind, rec.wind[k, 0])
    with pytest.raises(ConfigError, match="agent"):
        next(recording_observations(rec, 1))
    with pytest.raises(ConfigError, match="stride"):
        next(recording_observations(rec, 0, 0))
