"""Traces of a searcher's diagnostics over its own iterations, across episodes.

A searcher reports numbers every step through
:meth:`~odorloc.searchers.base.Searcher.diagnostics` (a team suffixes its members' keys with
``_<agent>``). :func:`diagnostic_traces` runs episodes of a scenario and keeps, for each member,
the value of one key each time another key (an iteration counter) moves on: e.g. the mean
particle position along the wind against a UAV's iteration, the mechanism figure of a filter's
drift (:func:`~odorloc.experiments.figures.trace_figure`). :func:`record_first_success` records
the first successful episode of a scenario, for a figure of one episode.
"""

from __future__ import annotations

import numpy as np

from odorloc.core.seeds import episode_seeds
from odorloc.engine.episode import Episode, EpisodeResult, run_episode
from odorloc.scenarios.config import Scenario

__all__ = ["diagnostic_traces", "record_first_success"]


def diagnostic_traces(
    scenario: Scenario,
    episodes: int,
    seed: int,
    value: str,
    counter: str,
    world_key: str | None = None,
) -> list[np.ndarray]:
    """One trace per (episode, member): ``value`` at each new value of ``counter``.

    Parameters
    ----------
    scenario : Scenario
        With the searcher to trace.
    episodes : int
        Episodes ``0 .. episodes-1`` of the root ``seed`` (the same seeds as a sweep's).
    seed : int
    value, counter : str
        Diagnostics keys; a team member's are the keys with its ``_<agent>`` suffix (the first
        member's bare).
    world_key : str, optional
        The world key of the seeds (default the scenario's name).

    Returns
    -------
    list of (K,) ndarray
        ``value`` after each of a member's ``K`` iterations, in episode and member order.
    """
    key = world_key or scenario.name
    out: list[np.ndarray] = []
    for e in range(episodes):
        ep = Episode(scenario, record=False)
        obs = ep.reset(*episode_seeds(seed, key, e))
        searcher = ep.built.searcher
        searcher.reset(ep.context, ep.agent_rng)
        runs: dict[str, list[float]] = {}
        last: dict[str, float] = {}
        while not ep.done:
            action = searcher.act(obs, ep.agent_rng)
            obs = ep.step(action, searcher).observations
            diag = searcher.diagnostics()
            for name, count in diag.items():
                if name != counter and not name.startswith(f"{counter}_"):
                    continue
                suffix = name[len(counter) :]
                if count != last.get(suffix):
                    last[suffix] = count
                    runs.setdefault(suffix, []).append(float(diag[f"{value}{suffix}"]))
        out += [np.array(v) for _, v in sorted(runs.items())]
    return out


def record_first_success(
    scenario: Scenario,
    seed: int,
    tries: int = 10,
    world_key: str | None = None,
    belief_stride: int = 5,
) -> tuple[int, EpisodeResult]:
    """The first of episodes ``0 .. tries-1`` (root ``seed``) that succeeds, recorded (or the
    last one tried): ``(episode, result)``; beliefs are kept every ``belief_stride`` steps."""
    rec = scenario.recording.model_copy(update={"belief_stride": belief_stride})
    sc = scenario.model_copy(update={"recording": rec})
    key = world_key or scenario.name
    for ep in range(tries):
        res = run_episode(sc, *episode_seeds(seed, key, ep), record=True)
        if res.metrics["success"]:
            break
    return ep, res
