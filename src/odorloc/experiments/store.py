"""Durable results store: one SQLite row per finished episode.

Why SQLite in WAL mode
----------------------
A sweep may be killed at any moment (pre-emption, Ctrl-C, a crashed node). Each finished episode is
committed in its own transaction, so after a kill the store holds exactly the episodes that
finished, never a half-written one; appending to CSV/Parquet cannot promise that (a torn last
line, a footer never written) and one file per episode scales poorly past a few thousand files.
SQLite ships with Python, keeps everything in one file, enforces ``UNIQUE(cell_id, episode)`` so a
resumed run can never duplicate an episode, and is read directly by pandas and DuckDB. Write-ahead
logging lets a report or a notebook read the store while the sweep is still writing, and with
``synchronous=NORMAL`` a commit costs tens of microseconds yet survives a killed process (only a
power cut can lose the last few commits, and even then the file stays consistent).

Only the parent process writes: workers return rows and the parent commits them as they arrive,
so there is no lock contention and no per-worker file.

Tables
------
``meta(key, value)``
    ``config_hash``, ``sweep`` (the sweep as JSON), ``schema``, ``created``.
``episodes``
    one row per episode: ids, seeds, the standard metrics (``success``, ``search_time`` s,
    ``path_length`` m, ``loc_error`` m, ``first_detection_time`` s, ``energy`` J, ``bytes``,
    ``steps``, ``termination``, ``start_distance`` m), ``status``, ``error``, ``wall_time`` s and
    any further numeric metrics as JSON in ``extra``.
``agent_metrics(cell_id, episode, agent, key, value)``
    values that belong to one agent of a team (a UAV's cue count, a group's declaration time),
    one row per agent and metric beside the episode row (:meth:`ResultStore.agent_frame`);
    never folded into ``key_<agent>`` column names.
``arrays``
    optional per-episode arrays (trajectories, beliefs) as ``.npz`` bytes.

Stores of schema 1 (written before per-agent values had their table) kept them in ``extra``
as ``key`` (the first member) and ``key_<agent>`` (the others); they are read through
:func:`split_legacy_extra`, the one place that knows that naming, and migrated in place the first
time such a store is opened for writing (a resumed sweep).

Query with DuckDB either through :meth:`ResultStore.duckdb` (no extension needed) or, where
DuckDB's ``sqlite`` extension is installed,
``duckdb.sql("select * from sqlite_scan('results.sqlite', 'episodes')")``.
"""

from __future__ import annotations

import io
import json
import math
import sqlite3
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from odorloc.core.errors import ConfigError

SCHEMA_VERSION = "2"

STANDARD_METRICS: dict[str, str] = {
    "success": "INTEGER",
    "search_time": "REAL",
    "path_length": "REAL",
    "loc_error": "REAL",
    "first_detection_time": "REAL",
    "energy": "REAL",
    "bytes": "INTEGER",
    "steps": "INTEGER",
    "termination": "TEXT",
    "start_distance": "REAL",
}
"""Metric columns of every row (name -> SQLite type); other numeric keys go to ``extra``."""

_ID_COLUMNS = [
    "cell_index",
    "cell_id",
    "world_key",
    "episode",
    "config_hash",
    "scenario",
    "searcher",
    "cell",
    "world_seed",
    "agent_seed",
]
_TAIL_COLUMNS = ["status", "error", "wall_time", "extra", "finished_at"]
COLUMNS = _ID_COLUMNS + list(STANDARD_METRICS) + _TAIL_COLUMNS
"""Columns of the ``episodes`` table, in order."""

VOLATILE_COLUMNS = (
    "wall_time",
    "finished_at",
    "wall_per_step_ms",
    "world_fraction",
    "searcher_fraction",
)
"""Columns that legitimately differ between two runs of the same sweep."""

AGENT_METRICS = "agent_metrics"
"""Row key (and table name) of the per-agent values: ``{agent id: {key: value}}`` in a row."""

_RESERVED = {"status", "error", "wall_time", "arrays", "traceback", AGENT_METRICS}


def connect_readonly(path: Path) -> sqlite3.Connection:
    """A read-only connection that leaves the store's folder as it is.

    A reader of a write-ahead-log database normally creates its ``-wal`` and ``-shm`` files;
    when there is no ``-wal`` file (the store was closed cleanly, everything is in the main
    file) the file is opened as immutable, which creates nothing.
    """
    wal = path.with_name(path.name + "-wal")
    extra = "" if wal.exists() else "&immutable=1"
    return sqlite3.connect(f"{Path(path).absolute().as_uri()}?mode=ro{extra}", uri=True)


def _create_sql() -> str:
    metric_cols = ",\n  ".join(f"{k} {t}" for k, t in STANDARD_METRICS.items())
    return f"""
CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS episodes (
  cell_index INTEGER NOT NULL,
  cell_id TEXT NOT NULL,
  world_key TEXT NOT NULL,
  episode INTEGER NOT NULL,
  config_hash TEXT NOT NULL,
  scenario TEXT,
  searcher TEXT,
  cell TEXT,
  world_seed INTEGER NOT NULL,
  agent_seed INTEGER NOT NULL,
  {metric_cols},
  status TEXT NOT NULL,
  error TEXT NOT NULL DEFAULT '',
  wall_time REAL,
  extra TEXT,
  finished_at REAL,
  UNIQUE (cell_id, episode)
);
CREATE TABLE IF NOT EXISTS agent_metrics (
  cell_id TEXT NOT NULL,
  episode INTEGER NOT NULL,
  agent INTEGER NOT NULL,
  key TEXT NOT NULL,
  value REAL,
  PRIMARY KEY (cell_id, episode, agent, key)
);
CREATE TABLE IF NOT EXISTS arrays (
  cell_id TEXT NOT NULL,
  episode INTEGER NOT NULL,
  npz BLOB NOT NULL,
  PRIMARY KEY (cell_id, episode)
);
"""


def _num(v: Any) -> Any:
    """A JSON/SQLite-friendly scalar (NaN becomes NULL, numpy scalars become Python)."""
    if v is None:
        return None
    if isinstance(v, np.generic):
        v = v.item()
    if isinstance(v, float) and not math.isfinite(v):
        return None if math.isnan(v) else v
    return v


def _error_text(row: Mapping[str, Any]) -> str:
    """The row's error line, followed by its traceback when the row carries one separately."""
    err = str(row.get("error", "") or "")
    tb = row.get("traceback")
    if isinstance(tb, str) and tb.strip() and tb.strip() not in err:
        err = f"{err}\n{tb.strip()}" if err else tb.strip()
    return err


def _finite_or_none(v: Any) -> Any:
    v = _num(v)
    return None if isinstance(v, float) and not math.isfinite(v) else v


def _is_number(v: Any) -> bool:
    return isinstance(v, int | float | bool | np.generic)


def split_legacy_extra(
    extra: Mapping[str, Any],
) -> tuple[dict[str, Any], dict[int, dict[str, Any]]]:
    """Episode columns and per-agent values of a schema-1 row's ``extra``.

    Schema-1 teams wrote their first member's values as ``key`` and the others' as
    ``key_<agent>``; a column ``key_<n>`` is read as agent ``n``'s value of ``key`` when the row
    also has ``key`` (which then is agent 0's). Indexed columns without such a base (the times
    sources were found, ``found_time_0``; per-peak values) stay episode columns.
    """
    suffixed: dict[str, tuple[str, int]] = {}
    for k in extra:
        base, sep, tail = k.rpartition("_")
        if sep and tail.isdigit() and base in extra:
            suffixed[k] = (base, int(tail))
    bases = {b for b, _ in suffixed.values()}
    agents: dict[int, dict[str, Any]] = {}
    for base in sorted(bases):
        agents.setdefault(0, {})[base] = extra[base]
    for k, (base, a) in suffixed.items():
        agents.setdefault(a, {})[base] = extra[k]
    rest = {k: v for k, v in extra.items() if k not in bases and k not in suffixed}
    return rest, {a: agents[a] for a in sorted(agents)}


def arrays_to_npz(arrays: Mapping[str, Any]) -> bytes:
    """Serialise a dict of arrays to compressed ``.npz`` bytes."""
    buf = io.BytesIO()
    np.savez_compressed(buf, **{k: np.asarray(v) for k, v in arrays.items()})
    return buf.getvalue()


def npz_to_arrays(data: bytes) -> dict[str, np.ndarray]:
    """Inverse of :func:`arrays_to_npz`."""
    with np.load(io.BytesIO(data), allow_pickle=False) as z:
        return {k: z[k] for k in z.files}


class ResultStore:
    """A SQLite file of episode results.

    Parameters
    ----------
    path : path
        The database file; created on first write unless ``readonly``.
    readonly : bool
        Open for reading only (reports, analysis); the file must exist.

    Raises
    ------
    ConfigError
        ``store`` if the file is not a results store (e.g. another SQLite database or not a
        database at all); nothing in it is modified.
    """

    def __init__(self, path: str | Path, readonly: bool = False) -> None:
        self.path = Path(path)
        self.readonly = readonly
        if readonly or self.path.exists():
            self._check_existing()
        if readonly:
            self._con = connect_readonly(self.path)
        else:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self._con = sqlite3.connect(self.path)
            self._con.execute("PRAGMA journal_mode=WAL")
            self._con.execute("PRAGMA synchronous=NORMAL")
            self._con.executescript(_create_sql())
            self._con.commit()
            if self.legacy:
                self._migrate()

    @property
    def schema(self) -> str:
        """The store's schema version (``"1"``: per-agent values still in ``extra``)."""
        tables = {r[0] for r in self._con.execute("SELECT name FROM sqlite_master")}
        if "meta" not in tables:
            return SCHEMA_VERSION
        got = self._con.execute("SELECT value FROM meta WHERE key = 'schema'").fetchone()
        if got is not None:
            return str(got[0])
        return SCHEMA_VERSION if "agent_metrics" in tables else "1"

    @property
    def legacy(self) -> bool:
        """Whether the store was written with schema 1 (read through
        :func:`split_legacy_extra`)."""
        return self.schema == "1" and len(self) > 0

    def _migrate(self) -> None:
        """Move a schema-1 store's per-agent values from ``extra`` to ``agent_metrics``."""
        rows = self._con.execute("SELECT cell_id, episode, extra FROM episodes").fetchall()
        with self._con:
            for cell_id, episode, extra in rows:
                rest, agents = split_legacy_extra(json.loads(extra) if extra else {})
                if not agents:
                    continue
                self._con.execute(
                    "UPDATE episodes SET extra = ? WHERE cell_id = ? AND episode = ?",
                    (json.dumps(rest, sort_keys=True) if rest else None, cell_id, episode),
                )
                self._insert_agents(cell_id, episode, agents)
            self._con.execute(
                "INSERT OR REPLACE INTO meta (key, value) VALUES ('schema', ?)", (SCHEMA_VERSION,)
            )

    def _insert_agents(
        self, cell_id: str, episode: int, agents: Mapping[int, Mapping[str, Any]]
    ) -> None:
        self._con.executemany(
            "INSERT OR REPLACE INTO agent_metrics (cell_id, episode, agent, key, value) "
            "VALUES (?, ?, ?, ?, ?)",
            [
                (cell_id, int(episode), int(a), str(k), _finite_or_none(v))
                for a, values in agents.items()
                for k, v in values.items()
                if _is_number(v)
            ],
        )

    # ------------------------------------------------------------------ lifecycle
    def _check_existing(self) -> None:
        if self.path.is_dir():
            raise ConfigError("store", f"{self.path} is a folder, not a results store")
        if not self.path.is_file():
            raise ConfigError("store", f"no results store at {self.path}")
        if self.path.stat().st_size == 0:
            if self.readonly:
                raise ConfigError("store", f"{self.path} is empty (0 bytes): no results stored")
            return
        try:
            con = connect_readonly(self.path)
            try:
                tables = {r[0] for r in con.execute("SELECT name FROM sqlite_master")}
                columns = {
                    t: {r[1] for r in con.execute(f"PRAGMA table_info({t})")}
                    for t in ("meta", "episodes", "arrays")
                    if t in tables
                }
            finally:
                con.close()
        except sqlite3.DatabaseError:
            raise ConfigError("store", f"{self.path} is not an odorloc results store") from None
        if not tables:
            if self.readonly:
                raise ConfigError("store", f"{self.path} is an empty database: no results stored")
            return
        if not {"meta", "episodes"} <= tables:
            raise ConfigError(
                "store", f"{self.path} is a database but not an odorloc results store"
            )
        wanted = {"meta": {"key", "value"}, "episodes": set(COLUMNS)}
        wanted["arrays"] = {"cell_id", "episode", "npz"}
        for t, cols in columns.items():
            missing = sorted(wanted[t] - cols)
            if missing:
                raise ConfigError(
                    "store",
                    f"{self.path} is not an odorloc results store: table {t!r} lacks "
                    f"column(s) {', '.join(missing[:5])}" + (" ..." if len(missing) > 5 else ""),
                )

    def close(self) -> None:
        """Close the connection (the data are already committed)."""
        self._con.close()

    def __enter__(self) -> ResultStore:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ------------------------------------------------------------------ meta
    def meta(self) -> dict[str, str]:
        """The ``meta`` table as a dict."""
        return dict(self._con.execute("SELECT key, value FROM meta"))

    @property
    def config_hash(self) -> str | None:
        """Config hash of the sweep this store belongs to (``None`` if still empty)."""
        return self.meta().get("config_hash")

    def check(self, chash: str) -> None:
        """Raise :class:`ConfigError` if the store belongs to a sweep other than ``chash``."""
        current = self.config_hash
        if current is not None and current != chash:
            raise ConfigError(
                "store",
                f"{self.path} holds results of a different sweep (config hash {current}, "
                f"this sweep {chash}); use another store path",
            )

    def bind(self, chash: str, sweep: Any = None) -> None:
        """Tie the store to the sweep with config hash ``chash``.

        An empty store records the hash (and the sweep as JSON); a store of the same sweep is
        accepted as is (resume); a store of another sweep is refused untouched.

        Raises
        ------
        ConfigError
            ``store`` on a config hash mismatch.
        """
        current = self.config_hash
        if current is None:
            if self.readonly:
                raise ConfigError("store", f"{self.path} holds no sweep")
            sweep_json = sweep.model_dump_json() if hasattr(sweep, "model_dump_json") else "{}"
            with self._con:
                self._con.executemany(
                    "INSERT OR REPLACE INTO meta (key, value) VALUES (?, ?)",
                    [
                        ("config_hash", chash),
                        ("sweep", sweep_json),
                        ("schema", SCHEMA_VERSION),
                        ("created", time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())),
                    ],
                )
        else:
            self.check(chash)

    # ------------------------------------------------------------------ writing
    def add(self, task: Any, row: Mapping[str, Any]) -> bool:
        """Commit one finished episode (and its arrays, if the row carries any).

        Parameters
        ----------
        task : EpisodeTask
        row : dict
            Metrics returned by the episode function (see the module docstring); an
            ``"arrays"`` entry (dict of arrays) is stored as an npz blob.

        Returns
        -------
        bool
            ``False`` if the episode was already stored (the stored row is kept).
        """
        cell = task.cell
        extra = {
            k: _finite_or_none(v)
            for k, v in row.items()
            if k not in STANDARD_METRICS and k not in _RESERVED and _is_number(v)
        }
        values: dict[str, Any] = {
            "cell_index": task.cell_index,
            "cell_id": task.cell_id,
            "world_key": task.world_key,
            "episode": task.episode,
            "config_hash": task.config_hash,
            "scenario": cell.get("scenario_label", cell.get("scenario")),
            "searcher": cell.get("searcher_label", cell.get("searcher")),
            "cell": json.dumps(cell, sort_keys=True),
            "world_seed": task.world_seed,
            "agent_seed": task.agent_seed,
            "status": str(row.get("status", "ok")),
            "error": _error_text(row),
            "wall_time": _num(row.get("wall_time")),
            "extra": json.dumps(extra, sort_keys=True, allow_nan=False) if extra else None,
            "finished_at": time.time(),
        }
        for k in STANDARD_METRICS:
            v = _num(row.get(k))
            if k == "success" and v is not None:
                v = int(bool(v))
            values[k] = v
        cols = ", ".join(COLUMNS)
        marks = ", ".join(f":{c}" for c in COLUMNS)
        with self._con:
            cur = self._con.execute(
                f"INSERT OR IGNORE INTO episodes ({cols}) VALUES ({marks})", values
            )
            inserted = cur.rowcount == 1
            agents = row.get(AGENT_METRICS)
            if inserted and agents:
                self._insert_agents(task.cell_id, task.episode, agents)
            arrays = row.get("arrays")
            if inserted and arrays:
                self._con.execute(
                    "INSERT OR REPLACE INTO arrays (cell_id, episode, npz) VALUES (?, ?, ?)",
                    (task.cell_id, task.episode, arrays_to_npz(arrays)),
                )
        return inserted

    def delete_errors(self) -> int:
        """Remove episodes stored with status ``"error"`` so they run again; returns the count."""
        with self._con:
            cur = self._con.execute("DELETE FROM episodes WHERE status = 'error'")
            for table in ("arrays", "agent_metrics"):
                self._con.execute(
                    f"DELETE FROM {table} WHERE NOT EXISTS (SELECT 1 FROM episodes e "
                    f"WHERE e.cell_id = {table}.cell_id AND e.episode = {table}.episode)"
                )
        return cur.rowcount

    # ------------------------------------------------------------------ reading
    def done_keys(self) -> set[tuple[str, int]]:
        """``{(cell_id, episode)}`` of every stored episode."""
        return {(c, int(e)) for c, e in self._con.execute("SELECT cell_id, episode FROM episodes")}

    def cell_counts(self, success: str = "success") -> dict[str, tuple[int, int, int]]:
        """Per cell: ``(episodes, successes, errors)`` stored so far; ``success`` names the
        column counted (a standard column or a numeric metric kept in ``extra``)."""
        if success == "success":
            hit = "success"
        elif success.isidentifier():
            hit = f"CAST(json_extract(extra, '$.{success}') AS INTEGER)"
        else:
            raise ConfigError("success", f"{success!r} is not a column name")
        q = (
            f"SELECT cell_id, COUNT(*), COALESCE(SUM({hit}), 0), "
            "SUM(CASE WHEN status = 'error' THEN 1 ELSE 0 END) FROM episodes GROUP BY cell_id"
        )
        return {c: (int(n), int(s), int(e)) for c, n, s, e in self._con.execute(q)}

    def __len__(self) -> int:
        return int(self._con.execute("SELECT COUNT(*) FROM episodes").fetchone()[0])

    def frame(self, volatile: bool = True, expand: bool = True, agents: bool = False) -> Any:
        """All episodes as a pandas DataFrame ordered by cell, episode.

        Parameters
        ----------
        volatile : bool
            Keep ``wall_time`` and ``finished_at`` (drop them to compare two runs).
        expand : bool
            Spread ``extra`` metrics into their own columns and add one column per swept
            parameter (``scenario.<key>``, ``searcher.<key>``).
        agents : bool
            Add the column ``agents``: each episode's per-agent values as a dict ``{agent id:
            {key: value}}`` (empty for episodes without any; see :meth:`agent_frame` for the
            long table).
        """
        import pandas as pd

        try:
            df = pd.read_sql_query(
                f"SELECT {', '.join(COLUMNS)} FROM episodes ORDER BY cell_index, episode",
                self._con,
            )
        except (sqlite3.DatabaseError, pd.errors.DatabaseError) as exc:
            reason = " ".join(str(exc).split())[-120:]
            raise ConfigError("store", f"cannot read {self.path}: {reason}") from None
        df["success"] = df["success"].astype("boolean")
        for k, t in STANDARD_METRICS.items():
            if t == "REAL":
                df[k] = df[k].astype(float)
            elif t == "INTEGER" and k != "success":
                df[k] = df[k].astype("Int64")
        df["wall_time"] = df["wall_time"].astype(float)
        df["finished_at"] = df["finished_at"].astype(float)
        if self.legacy:
            df["extra"] = [
                json.dumps(split_legacy_extra(json.loads(x))[0], sort_keys=True)
                if isinstance(x, str) and x
                else x
                for x in df["extra"]
            ]
        if agents:
            df["agents"] = agent_dicts(self.agent_frame(), df)
        if expand:
            df = expand_frame(df)
        if not volatile:
            df = df.drop(columns=[c for c in VOLATILE_COLUMNS if c in df.columns])
        return df.reset_index(drop=True)

    def agent_frame(self) -> Any:
        """The per-agent values as a long table: columns ``cell_id, episode, agent, key,
        value``, ordered by cell, episode, agent and key (one row per agent and metric)."""
        import pandas as pd

        if self.legacy:
            rows = []
            q = "SELECT cell_id, episode, extra FROM episodes ORDER BY cell_index, episode"
            for cell_id, episode, extra in self._con.execute(q):
                _, agents = split_legacy_extra(json.loads(extra) if extra else {})
                rows += [
                    (cell_id, int(episode), a, k, v)
                    for a, values in agents.items()
                    for k, v in sorted(values.items())
                ]
        else:
            rows = self._con.execute(
                "SELECT m.cell_id, m.episode, m.agent, m.key, m.value FROM agent_metrics m "
                "JOIN episodes e ON m.cell_id = e.cell_id AND m.episode = e.episode "
                "ORDER BY e.cell_index, m.episode, m.agent, m.key"
            ).fetchall()
        df = pd.DataFrame(rows, columns=list(AGENT_COLUMNS))
        df["episode"] = df["episode"].astype(int)
        df["agent"] = df["agent"].astype(int)
        df["value"] = df["value"].astype(float)
        return df

    def arrays(self, cell_id: str, episode: int) -> dict[str, np.ndarray] | None:
        """Stored arrays of one episode, or ``None``."""
        r = self._con.execute(
            "SELECT npz FROM arrays WHERE cell_id = ? AND episode = ?", (cell_id, int(episode))
        ).fetchone()
        return None if r is None else npz_to_arrays(r[0])

    def episodes_with_arrays(self) -> list[tuple[str, int]]:
        """``(cell_id, episode)`` of every episode with stored arrays."""
        rows = self._con.execute(
            "SELECT a.cell_id, a.episode FROM arrays a JOIN episodes e "
            "ON a.cell_id = e.cell_id AND a.episode = e.episode ORDER BY e.cell_index, e.episode"
        )
        return [(c, int(e)) for c, e in rows]

    # ------------------------------------------------------------------ export
    def to_csv(self, path: str | Path) -> Path:
        """Write the episode table as CSV, and the per-agent table (when there are per-agent
        values) beside it as :func:`agents_path`; returns the episode table's path."""
        path = Path(path)
        self.frame().to_csv(path, index=False)
        agents = self.agent_frame()
        if len(agents):
            agents.to_csv(agents_path(path), index=False)
        return path

    def to_parquet(self, path: str | Path) -> Path:
        """Write the episode table as Parquet (needs pyarrow), and the per-agent table beside
        it as :func:`agents_path`; returns the episode table's path."""
        path = Path(path)
        df = self.frame()
        df["success"] = df["success"].astype("boolean")
        df.to_parquet(path, index=False)
        agents = self.agent_frame()
        if len(agents):
            agents.to_parquet(agents_path(path), index=False)
        return path

    def duckdb(self) -> Any:
        """An in-memory DuckDB connection with the episode table registered as ``episodes``.

        Needs the optional extra ``duckdb``. Example:
        ``store.duckdb().sql("select searcher, avg(success::int) from episodes group by 1")``.
        """
        try:
            import duckdb
        except ImportError as exc:
            raise ConfigError("duckdb", "install the extra: pip install 'odorloc[duckdb]'") from exc
        con = duckdb.connect()
        con.register("episodes", self.frame())
        con.register("agent_metrics", self.agent_frame())
        return con


AGENT_COLUMNS = ("cell_id", "episode", "agent", "key", "value")
"""Columns of the per-agent table (:meth:`ResultStore.agent_frame`, the ``*_agents`` exports)."""


def agents_path(path: str | Path) -> Path:
    """Where an export of the episode table at ``path`` puts the per-agent table
    (``results.csv`` -> ``results_agents.csv``)."""
    p = Path(path)
    return p.with_name(f"{p.stem}_agents{p.suffix}")


def agent_dicts(agents: Any, episodes: Any) -> list[dict[int, dict[str, float]]]:
    """For each row of ``episodes`` (columns ``cell_id, episode``), its per-agent values from
    the long table ``agents`` as ``{agent id: {key: value}}`` (empty when it has none)."""
    by: dict[tuple[str, int], dict[int, dict[str, float]]] = {}
    for c, e, a, k, v in agents[list(AGENT_COLUMNS)].itertuples(index=False, name=None):
        by.setdefault((str(c), int(e)), {}).setdefault(int(a), {})[str(k)] = float(v)
    return [
        by.get((str(c), int(e)), {})
        for c, e in episodes[["cell_id", "episode"]].itertuples(index=False, name=None)
    ]


def agent_table(episodes: Any) -> Any:
    """The long per-agent table (:data:`AGENT_COLUMNS`, plus ``sweep`` when ``episodes`` has
    it) of an episode frame that carries the ``agents`` column."""
    import pandas as pd

    cols = list(AGENT_COLUMNS) + (["sweep"] if "sweep" in episodes.columns else [])
    if "agents" not in episodes.columns or not len(episodes):
        return pd.DataFrame(columns=cols)
    keys = ["cell_id", "episode"] + (["sweep"] if "sweep" in episodes.columns else [])
    rows = [
        (*ids[:2], a, k, v, *ids[2:])
        for *ids, d in episodes[[*keys, "agents"]].itertuples(index=False, name=None)
        for a, values in sorted((d or {}).items())
        for k, v in sorted(values.items())
    ]
    return pd.DataFrame(rows, columns=cols)


def agent_values(episodes: Any, key: str) -> Any:
    """One per-agent metric of each episode as a frame: rows as ``episodes`` (which carries the
    ``agents`` column of :meth:`ResultStore.frame`), one column per agent id (NaN where an
    agent has no such value)."""
    import pandas as pd

    recs = [
        {a: v[key] for a, v in (d or {}).items() if key in v}
        for d in episodes.get("agents", pd.Series([{}] * len(episodes), index=episodes.index))
    ]
    out = pd.DataFrame.from_records(recs, index=episodes.index)
    return out.reindex(columns=sorted(out.columns)).astype(float)


def expand_frame(df: Any) -> Any:
    """Add the ``extra`` metrics and the swept parameters as columns of an episode table."""
    import pandas as pd

    new: dict[str, Any] = {}
    if "extra" in df.columns:
        extras = [json.loads(x) if isinstance(x, str) and x else {} for x in df["extra"]]
        keys = sorted({k for e in extras for k in e})
        for k in keys:
            if k not in df.columns:
                new[k] = pd.array([e.get(k, np.nan) for e in extras], dtype=float)
    if "cell" in df.columns:
        swept = [json.loads(x).get("swept", {}) if isinstance(x, str) else {} for x in df["cell"]]
        keys = sorted({k for s in swept for k in s})
        for k in keys:
            if k not in df.columns and k not in new:
                new[k] = [s.get(k) for s in swept]
    if not new:
        return df
    # one concatenation instead of one insertion per column (no fragmented frame)
    return pd.concat([df, pd.DataFrame(new, index=df.index)], axis=1)


REQUIRED_COLUMNS = ("cell_id", "world_key", "episode", "scenario", "searcher", "status")
"""Columns a results table (store, CSV or Parquet export) must have, with the standard
metrics."""


def check_results_frame(df: Any, source: str = "results") -> Any:
    """``df`` with its standard columns typed, or :class:`ConfigError` if it is not a results
    table (missing columns, a metric column that is not numeric)."""
    import pandas as pd

    missing = [c for c in (*REQUIRED_COLUMNS, *STANDARD_METRICS) if c not in df.columns]
    if missing:
        more = " ..." if len(missing) > 5 else ""
        raise ConfigError(
            "results",
            f"{source} is not an odorloc results table: no column(s) "
            f"{', '.join(missing[:5])}{more}",
        )
    df = df.copy()
    for k, t in STANDARD_METRICS.items():
        if t == "TEXT":
            df[k] = df[k].astype("string").fillna("")
            continue
        col = df[k]
        if k == "success":
            col = col.map(
                lambda v: (
                    {"true": 1, "false": 0}.get(v.strip().lower(), v) if isinstance(v, str) else v
                )
            )
        try:
            num = pd.to_numeric(col)
        except (ValueError, TypeError):
            raise ConfigError(
                "results", f"{source}: column {k!r} holds values that are not numbers"
            ) from None
        if k == "success":
            df[k] = num.astype("Float64").astype("boolean")
        else:
            df[k] = num.astype(float)
    try:
        df["episode"] = pd.to_numeric(df["episode"]).astype(int)
    except (ValueError, TypeError):
        raise ConfigError("results", f"{source}: column 'episode' must hold integers") from None
    df["status"] = df["status"].astype("string").fillna("ok")
    if "error" not in df.columns:
        df["error"] = ""
    df["error"] = df["error"].astype("string").fillna("")
    return df


def open_results(source: Any) -> Any:
    """A results DataFrame from a store, a store path, a CSV/Parquet file or a DataFrame.

    Raises
    ------
    ConfigError
        ``results``: a file that cannot be read as a table or is not a results table;
        ``store``: a database that is not a results store.
    """
    import pandas as pd

    if isinstance(source, pd.DataFrame):
        return source
    if isinstance(source, ResultStore):
        return source.frame()
    path = Path(source)
    if path.suffix in (".csv", ".parquet", ".pq"):
        if not path.is_file():
            raise ConfigError("results", f"no such file: {path}")
        try:
            if path.suffix == ".csv":
                df = pd.read_csv(path, encoding="utf-8", low_memory=False)
            else:
                df = pd.read_parquet(path)
        except Exception as exc:  # any reader failure means the file is not a table we can use
            reason = " ".join(str(exc).split())[:120] or type(exc).__name__
            raise ConfigError("results", f"cannot read {path} as a table: {reason}") from None
        return expand_frame(check_results_frame(df, str(path)))
    with ResultStore(path, readonly=True) as st:
        return st.frame()
