"""A recorded episode as a stream of observations, for estimators run offline on it.

An episode's :class:`~odorloc.engine.recorder.Recording` keeps every agent's position, reading,
detection and anemometer wind at each recorded step; :func:`recording_observations` gives them
back as :class:`~odorloc.core.types.Observation` objects, so that another estimator can be fed
exactly the readings a searcher took (e.g. a source-term posterior beside the Dempster-Shafer map
built on the same flight).
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from odorloc.core.errors import ConfigError
from odorloc.core.types import Observation
from odorloc.engine.recorder import Recording

__all__ = ["recording_observations"]


def recording_observations(
    rec: Recording, agent: int = 0, stride: int = 1
) -> Iterator[Observation]:
    """Agent ``agent``'s observations of a recording, every ``stride``-th recorded step.

    Parameters
    ----------
    rec : Recording
    agent : int
        Column of the agent in the recording.
    stride : int
        Keep every ``stride``-th step (the first included).

    Raises
    ------
    ConfigError
        For an agent the recording does not have or a stride below 1.
    """
    if not 0 <= agent < rec.positions.shape[1]:
        raise ConfigError("agent", f"the recording has {rec.positions.shape[1]} agent(s)")
    if stride < 1:
        raise ConfigError("stride", f"must be >= 1, got {stride}")
    for k in range(0, len(rec.t), stride):
        pos = np.asarray(rec.positions[k, agent], float)
        yield Observation(
            agent=agent,
            t=float(rec.t[k]),
            position=pos,
            heading=0.0,
            gas=float(rec.gas[k, agent]),
            detection=bool(rec.detection[k, agent]),
            wind=np.asarray(rec.wind[k, agent], float),
        )
