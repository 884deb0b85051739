"""Re-run one stored episode of a sweep or a reproduction alone, with its full recording.

A results store keeps, for every episode, the cell it belongs to (scenario, searcher and every
override, as JSON) and the two seeds it ran with. That is all an episode needs: rebuilding the
cell's scenario and running it with the same seeds gives the same episode, bit for bit, in
this process, now with the recording, figures and animation a batch does not keep.

Episodes of a ``replay: true`` sweep ran on a recorded flow; the flow is recorded again from
the same world seed (it depends on nothing else) and replayed, as the batch did.

The standard metrics of the new run are compared with the stored row
(:func:`differences`), so a researcher sees at once whether the episode repeated. They differ
only when something the episode depends on changed since the batch ran: the package, a file
the scenario reads, or an installation with other compiled kernels.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from odorloc.core.errors import ConfigError

__all__ = ["StoredEpisode", "differences", "rerun", "store_file", "stored_episode"]

#: an episode's summary metrics, in the order ``odorloc run`` prints them; all are compared
#: between the stored row and the new run (the timing columns, printed after them, legitimately
#: differ)
COMPARED = (
    "success",
    "termination",
    "search_time",
    "loc_error",
    "path_length",
    "first_detection_time",
    "energy",
    "bytes",
    "start_distance",
    "steps",
)


@dataclass(frozen=True)
class StoredEpisode:
    """One stored episode: where it came from and what it gave.

    Attributes
    ----------
    store : Path
        The results store (``.sqlite``).
    cell_id : str
    episode : int
    cell : dict
        The cell as the batch ran it (see :func:`~odorloc.experiments.runner.cell_scenario`).
    world_seed, agent_seed : int
        Its seeds.
    row : dict
        The stored metrics (standard and extra), ``status``, ``error`` and ``wall_time``.
    replay : bool
        Whether it ran on a recorded flow (``replay: true``).
    """

    store: Path
    cell_id: str
    episode: int
    cell: dict[str, Any]
    world_seed: int
    agent_seed: int
    row: dict[str, Any]
    replay: bool


def store_file(source: str | Path, field: str = "--from-batch") -> Path:
    """The store of a batch or reproduction output folder, or ``source`` itself if a file.

    A batch folder holds ``results.sqlite``; a reproduction folder one ``<sweep>.sqlite`` per
    sweep, of which one must then be named.
    """
    p = Path(source)
    if p.is_file():
        return p
    if not p.is_dir():
        raise ConfigError(field, f"{p} does not exist")
    if (p / "results.sqlite").is_file():
        return p / "results.sqlite"
    stores = sorted(q.name for q in p.glob("*.sqlite"))
    if len(stores) == 1:
        return p / stores[0]
    if not stores:
        raise ConfigError(field, f"{p} holds no results store (*.sqlite)")
    raise ConfigError(field, f"{p} holds {len(stores)} stores: name one ({', '.join(stores)})")


def stored_episode(
    source: str | Path, cell_id: str | None, episode: int, field: str = "--from-batch"
) -> StoredEpisode:
    """Look up episode ``episode`` of cell ``cell_id`` (``None``: the store's only cell).

    Raises
    ------
    ConfigError
        Naming ``field``, ``--cell`` or ``--episode``: no such store, cell or episode, or a row
        that does not say how it ran.
    """
    from odorloc.experiments.store import STANDARD_METRICS, ResultStore

    path = store_file(source, field)
    try:
        opened = ResultStore(path, readonly=True)
    except ConfigError as exc:
        # the file the caller named (e.g. the option --from-batch), not the library's word
        raise ConfigError(field, exc.problem) from None
    with opened as store:
        con = store._con
        cells = [r[0] for r in con.execute("SELECT DISTINCT cell_id FROM episodes ORDER BY 1")]
        if not cells:
            raise ConfigError(field, f"{path} holds no episodes")
        if cell_id is None:
            if len(cells) > 1:
                raise ConfigError("--cell", f"{path} holds {len(cells)} cells: {_few(cells)}")
            cell_id = cells[0]
        elif cell_id not in cells:
            raise ConfigError("--cell", f"no cell {cell_id!r} in {path}: {_few(cells)}")
        cols = ["cell", "world_seed", "agent_seed", "status", "error", "wall_time", "extra"]
        cols += list(STANDARD_METRICS)
        r = con.execute(
            f"SELECT {', '.join(cols)} FROM episodes WHERE cell_id = ? AND episode = ?",
            (cell_id, int(episode)),
        ).fetchone()
        if r is None:
            have = [
                int(v[0])
                for v in con.execute(
                    "SELECT episode FROM episodes WHERE cell_id = ? ORDER BY episode", (cell_id,)
                )
            ]
            span = (
                f"{have[0]}-{have[-1]}"
                if have == list(range(have[0], have[-1] + 1))
                else (_few([str(h) for h in have]))
            )
            raise ConfigError(
                "--episode", f"cell {cell_id!r} has no stored episode {episode} (stored: {span})"
            )
    row = dict(zip(cols, r, strict=True))
    try:
        cell = json.loads(row.pop("cell") or "null")
    except json.JSONDecodeError:
        cell = None
    if not isinstance(cell, dict) or "scenario" not in cell:
        raise ConfigError("--cell", f"{cell_id!r}: the stored row does not say which scenario ran")
    extra = json.loads(row.pop("extra") or "{}")
    row = {**extra, **row}
    return StoredEpisode(
        store=path,
        cell_id=cell_id,
        episode=int(episode),
        cell=cell,
        world_seed=int(row.pop("world_seed")),
        agent_seed=int(row.pop("agent_seed")),
        row=row,
        replay=bool(extra.get("replay", False)),
    )


def _few(items: list[str], n: int = 4) -> str:
    shown = ", ".join(repr(i) for i in items[:n])
    return shown + (f", ... ({len(items)} in all)" if len(items) > n else "")


def rerun(
    stored: StoredEpisode, record: bool = True, recording: Mapping[str, Any] | None = None
) -> tuple[Any, Any]:
    """Run the stored episode again; returns ``(scenario, EpisodeResult)``.

    ``recording`` overrides the scenario's recording settings (e.g. ``{"belief_stride": 1}``
    to keep every belief, which a batch does not); they change what is kept, never the
    episode.
    """
    from odorloc.engine.episode import run_episode
    from odorloc.experiments.runner import cell_scenario

    sc = cell_scenario(stored.cell)
    if recording:
        sc = sc.model_copy(update={"recording": sc.recording.model_copy(update=dict(recording))})
    if not stored.replay:
        return sc, run_episode(sc, stored.world_seed, stored.agent_seed, record=record)
    from odorloc.engine.replay import on_replay, record_flow

    movie = record_flow(sc, stored.world_seed)
    sc_r, built = on_replay(sc, movie)
    res = run_episode(sc_r, stored.world_seed, stored.agent_seed, built=built, record=record)
    return sc, res


def _same(a: Any, b: Any) -> bool:
    if a is None or b is None:
        return (a is None or (isinstance(a, float) and math.isnan(a))) and (
            b is None or (isinstance(b, float) and math.isnan(b))
        )
    if isinstance(a, str) or isinstance(b, str):
        return str(a) == str(b)
    fa, fb = float(a), float(b)
    if math.isnan(fa) and math.isnan(fb):
        return True
    return fa == fb


def differences(stored: StoredEpisode, metrics: dict[str, Any]) -> list[str]:
    """The compared metrics (:data:`COMPARED`) whose new value is not the stored one."""
    out = []
    for k in COMPARED:
        new = metrics.get(k)
        if k == "success" and new is not None:
            new = int(bool(new))
        if not _same(stored.row.get(k), new):
            out.append(k)
    return out
