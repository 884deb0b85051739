"""Tables and figures of a reproduction made of sweeps over a paper's points, and
:class:`PointsReproduction`, the base class of such a reproduction.

Given the points of a world (:class:`~odorloc.experiments.claims.Points`), the paper's sweeps
(:class:`~odorloc.experiments.variants.Sweep`) and the methods compared:

- :func:`sweep_tables`: per sweep, a success-rate and a mean-time table (one column per method,
  95 % intervals), plus the long rows of every point for ``points.csv``;
- :func:`claims_tables`: the judged statements (:class:`~odorloc.experiments.claims.Claim`), one
  table per world;
- :func:`points_table`: the long rows as a CSV-only table;
- :func:`sweep_figures`: one :func:`~odorloc.experiments.figures.sweep_figure` per sweep;
- :func:`means_table`: per method, the means of chosen row columns (with the paper's numbers);
- :func:`success_by_table`: per point and method, the success rate by a time and overall.
"""

from __future__ import annotations

import math
import textwrap
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from odorloc.core.errors import ConfigError
from odorloc.experiments.claims import (
    POINT_COLUMNS,
    Cells,
    Claim,
    Points,
    summarize_point,
    summary_texts,
    sweep_rows,
)
from odorloc.experiments.reproduction import (
    CONSOLE_WIDTH,
    Figure,
    Reproduction,
    Table,
    console_headers,
    fmt,
)
from odorloc.experiments.variants import Sweep

__all__ = [
    "PointsReproduction",
    "World",
    "claims_tables",
    "means_table",
    "points_table",
    "success_by_table",
    "sweep_figures",
    "sweep_tables",
]


def sweep_tables(
    data: Points,
    sweeps: Sequence[Sweep],
    methods: Sequence[str],
    names: Mapping[str, str],
    seed: int,
    at: float,
    world: str,
    note: str = "",
    statements: Mapping[str, str] | None = None,
    console: bool = True,
) -> tuple[list[Table], list[list[str]]]:
    """The two tables of every sweep (named ``<world>_<key>_sr`` and ``_mst``; one too wide for
    the console with its intervals is printed as ``..._means``, the values alone) and the long rows
    ``[world, sweep key, *POINT_COLUMNS]`` of every point (``at``: the time, s, of the last
    column's success rate). ``statements``: the paper's words per sweep key, under its tables."""
    tables, long = [], []
    for sw in sweeps:
        sr, mst, rows = sweep_rows(
            data, sw.values, sw.setting, sw.tick, methods, seed, at, (world, sw.key)
        )
        long += rows
        if not console:
            continue
        head = [sw.xlabel.split(" (")[0], *(names.get(a, a) for a in methods)]
        title = f"{sw.figure}, {world} world: %s against {sw.xlabel}"
        words = (statements or {}).get(sw.key, "")
        notes = "\n".join(t for t in (note, words) if t)
        parts = (("sr", "success rate %", sr), ("mst", "mean search time s", mst))
        for j, (suffix, what, cells) in enumerate(parts):
            last = j == len(parts) - 1
            # values with their intervals are wide: with many methods the console gets the
            # values alone, the intervals go to the CSV and the report
            fits = _console_width(head, cells) <= CONSOLE_WIDTH
            tables.append(
                Table(
                    f"{world}_{sw.key}_{suffix}",
                    title % f"{what} [95 %]",
                    head,
                    cells,
                    console=fits,
                    note=notes if last else "",
                )
            )
            if not fits:
                values = [[r[0], *(c.split(" [")[0] for c in r[1:])] for r in cells]
                tables.append(
                    Table(
                        f"{world}_{sw.key}_{suffix}_means",
                        title % f"{what} (intervals in the report)",
                        head,
                        values,
                        note=notes if last else "",
                    )
                )
    return tables, long


def _console_width(head: Sequence[str], rows: Sequence[Sequence[str]]) -> int:
    """Columns a console table of ``head`` and ``rows`` needs at least: each column as wide as
    its widest cell and header (a word of it for the first, which may wrap; a line of it as
    :func:`~odorloc.experiments.reproduction.console_headers` folds it for the others), two
    spaces between columns."""
    shown = console_headers(head, rows)
    widths = [
        max([len(w) for w in (h.split() if i == 0 else h.splitlines())] + [len(r[i]) for r in rows])
        for i, h in enumerate(shown)
    ]
    return sum(widths) + 2 * len(widths)


def claims_tables(claims: Sequence[Claim]) -> list[Table]:
    """One table of statements per world, in the order the worlds first appear."""
    out = []
    for world in dict.fromkeys(c.world for c in claims):
        out.append(
            Table(
                f"claims_{world}",
                f"The paper's statements in the {world} world (95 % intervals)",
                ["statement", "paper", "ours [95 % interval]", "verdict"],
                [c.row()[1:] for c in claims if c.world == world],
                note="held / not held: the interval lies on the claimed / the other side; "
                "undecided: it straddles it\n(pts: percentage points of success rate; s: "
                "seconds of mean search time).",
                left=4,
                widths=(5, 2, 9, 2),
            )
        )
    return out


def points_table(long: list[list[str]], at: float) -> Table:
    """The long rows of :func:`sweep_tables` as ``points`` (CSV and report only)."""
    head = ["world", "sweep", *POINT_COLUMNS]
    head[-1] = f"SR by {at:g} s %"
    return Table(
        "points",
        "Every point: success rate and mean search time with intervals",
        head,
        long,
        console=False,
    )


def sweep_figures(
    data: Points,
    sweeps: Sequence[Sweep],
    methods: Sequence[str],
    names: Mapping[str, str],
    colors: Mapping[str, str],
    seed: int,
    world: str,
    files: Mapping[str, str],
    limit: float,
    categorical: Sequence[str] = (),
) -> list[Figure]:
    """One figure per sweep, ``files[sweep key]``; sweeps named in ``categorical`` get a
    categorical axis (e.g. areas)."""
    from odorloc.experiments.figures import sweep_figure

    def draw(sw: Sweep) -> Any:
        return lambda p: sweep_figure(
            data,
            sw.values,
            sw.setting,
            methods,
            p,
            seed,
            f"{sw.figure}, {world} world",
            sw.xlabel,
            names,
            colors,
            sw.tick if sw.key in categorical else None,
            limit,
        )

    return [
        Figure(
            files[sw.key],
            f"{sw.figure}: mean search time and success rate against {sw.xlabel}, {world} "
            "world (95 % intervals)",
            draw(sw),
        )
        for sw in sweeps
    ]


def means_table(
    name: str,
    title: str,
    df: Any,
    methods: Sequence[str],
    names: Mapping[str, str],
    columns: Mapping[str, tuple[str, float, int]],
    reference: Mapping[str, str] | None = None,
    note: str = "",
) -> Table:
    """Per method (column ``searcher`` of ``df``), the mean of each row column:
    ``columns[header] = (column, scale, digits)``; ``reference``: the paper's text per method,
    in a last column."""
    from odorloc.experiments.reproduction import fmt

    rows = []
    for m in methods:
        h = df[df["searcher"] == m]
        if len(h):
            cells = [
                fmt(float(h[c].mean()) * s if c in h else math.nan, d)
                for c, s, d in columns.values()
            ]
            rows.append([names.get(m, m), *cells, *([reference.get(m, "-")] if reference else [])])
    head = ["algorithm", *columns, *(["paper"] if reference else [])]
    return Table(name, title, head, rows, note=note)


def success_by_table(
    name: str,
    title: str,
    data: Points,
    points: Sequence[Any],
    where: Any,
    methods: Sequence[str],
    names: Mapping[str, str],
    at: float,
    note: str = "",
) -> Table:
    """Per point (named by ``where(point)``) and method: ``SR by at / SR overall`` in %."""
    from odorloc.experiments.reproduction import fmt

    rows = []
    for p in points:
        row = [where(p)]
        for m in methods:
            g = data.one(p, m)
            by = float((g["success"] & (g["time"] <= at)).mean()) if len(g) else math.nan
            whole = float(g["success"].mean()) if len(g) else math.nan
            row.append(f"{fmt(100 * by, 0)} / {fmt(100 * whole, 0)}")
        rows.append(row)
    return Table(name, title, ["setting", *(names.get(m, m) for m in methods)], rows, note=note)


@dataclass(frozen=True)
class World:
    """One world of a :class:`PointsReproduction`.

    Attributes
    ----------
    name : str
        Its name in store and table names (e.g. ``rate``).
    scenario : str
        The base scenario.
    sweeps : sequence of Sweep
        The paper's sweeps run in it.
    episodes : int
        Episodes per cell of the default run.
    replay : bool
        Record each world's flow once per episode and replay it to every searcher.
    console : bool
        Print its per-sweep tables (they always go to ``points.csv``).
    curves : str
        File of its success-against-time figure (a world after the first; default
        ``success_time_<name>.png``).
    methods : tuple of str
        The methods of its per-sweep tables and figures (default: the reproduction's
        :attr:`~PointsReproduction.methods`), e.g. with an ablation run at every point of this
        world only.
    """

    name: str
    scenario: str
    sweeps: Sequence[Sweep]
    episodes: int
    replay: bool = False
    console: bool = True
    curves: str = ""
    methods: tuple[str, ...] = ()


class PointsReproduction(Reproduction):
    """A reproduction made of a paper's sweeps over points, in one or more worlds.

    A subclass declares its :attr:`methods`, their :attr:`names` and :attr:`colors`, the
    :attr:`columns` of a cell (:class:`~odorloc.experiments.claims.Cells`), and implements
    :meth:`worlds`, :meth:`sweep_files` (a world's sweep dictionaries,
    :func:`~odorloc.experiments.variants.variant_sweeps`) and :meth:`cell_of`; it may add
    :meth:`claims`, :meth:`extra_tables` and :meth:`extra_figures`. This class writes, per
    world, the per-sweep tables and ``points.csv``; at :attr:`default_point` (if set) a table
    per world of every method (and :attr:`extra_methods`) and ``comparison.png``; the claims
    tables; the first world's per-sweep figures (:attr:`figure_files`) and, for every other
    world, ``success_time_<world>.png`` (success against time per sweep, the first world
    dashed).
    """

    methods: ClassVar[tuple[str, ...]] = ()
    extra_methods: ClassVar[tuple[str, ...]] = ()
    names: ClassVar[Mapping[str, str]] = {}
    colors: ClassVar[Mapping[str, str]] = {}
    columns: ClassVar[Mapping[str, str]] = {"time": "search_time"}
    statements: ClassVar[Mapping[str, str]] = {}
    figure_files: ClassVar[Mapping[str, str]] = {}
    categorical: ClassVar[tuple[str, ...]] = ()
    default_point: ClassVar[Any] = None
    #: Episode limit (failures count it) and the time of the "success by" columns, seconds.
    limit: float = 1200.0
    at: float = 1200.0
    note: str = ""
    has_points = True
    #: Run only the default point of each world (:meth:`select_points`).
    default_only: bool = False

    def select_points(self, points: str) -> None:
        super().select_points(points)
        if points == "default" and self.default_point is None:
            raise ConfigError("points", f"{self.name} names no default point")
        self.default_only = points == "default"

    def _methods(self, world: World) -> tuple[str, ...]:
        """The methods of a world's per-sweep tables and figures."""
        return world.methods or self.methods

    def _every(self) -> tuple[str, ...]:
        """Every method of any world and the extra ones, once each, in order."""
        every = [*self.methods, *(m for w in self.worlds() for m in w.methods)]
        return tuple(dict.fromkeys([*every, *self.extra_methods]))

    def worlds(self) -> list[World]:
        """The worlds, in running order."""
        raise NotImplementedError

    def sweep_files(self, world: World, episodes: int, seed: int) -> dict[str, dict[str, Any]]:
        """The world's sweeps by part name (``""`` for the main one)."""
        raise NotImplementedError

    def cell_of(self, world: World, point: Any, method: str) -> tuple[str, str]:
        """``(world key, searcher label)`` of a method at a point of a world."""
        raise NotImplementedError

    def rows(self, df: Any) -> Any:
        """The stored rows made ready for :class:`Cells` (default: as they are)."""
        return df

    def claims(self, points: Mapping[str, Points], seed: int) -> list[Claim]:
        """The paper's statements judged (default none)."""
        return []

    def extra_tables(self, df: Any, points: Mapping[str, Points], seed: int) -> list[Table]:
        """More tables, after the per-sweep and default-point ones (default none)."""
        return []

    def extra_figures(self, df: Any, points: Mapping[str, Points], seed: int) -> list[Figure]:
        """More figures, after the others (default none)."""
        return []

    def sweeps(self, episodes: int | None, seed: int) -> dict[str, dict[str, Any]]:
        out: dict[str, dict[str, Any]] = {}
        for w in self._worlds():
            n = w.episodes if episodes is None else int(episodes)
            files = self.sweep_files(w, n, seed)
            out.update({f"{w.name}-{k}" if k else w.name: v for k, v in files.items()})
        return out

    def _worlds(self) -> list[World]:
        worlds = [w for w in self.worlds() if w.sweeps]
        if not self.default_only:
            return worlds
        # every sweep cut to its value at the default point (a sweep without it is left out)
        out = []
        for w in worlds:
            cut = []
            for s in w.sweeps:
                at = tuple(v for v in s.values if s.setting(v) == self.default_point)
                if at:
                    cut.append(replace(s, values=at))
            if cut:
                out.append(replace(w, sweeps=cut))
        return out

    def points(self, df: Any) -> dict[str, Points]:
        """The points of every world with sweeps."""
        cells = Cells(self.rows(df) if len(df) else df, self.columns)
        return {
            w.name: Points(cells, lambda p, m, w=w: self.cell_of(w, p, m)) for w in self._worlds()
        }

    def tables(self, df: Any, seed: int) -> list[Table]:
        if not len(df):
            return []
        points, out, long = self.points(df), [], []
        for w in self._worlds():
            t, rows = sweep_tables(
                points[w.name],
                w.sweeps,
                self._methods(w),
                self.names,
                seed,
                self.at,
                w.name,
                self.note,
                self.statements,
                w.console,
            )
            # with the default point alone, its table says all the sweep tables would
            out, long = (out if self.default_only else out + t), long + rows
            if self.default_point is not None:
                table = self._default_table(points[w.name], w.name, seed)
                if table.rows:  # a world whose episodes are not (yet) run
                    out.append(table)
        out += self.extra_tables(df, points, seed)
        return [*out, *claims_tables(self.claims(points, seed)), points_table(long, self.at)]

    def _default_table(self, data: Points, world: str, seed: int) -> Table:
        rows = []
        for i, m in enumerate(self._every()):
            p = summarize_point(data.one(self.default_point, m), np.random.default_rng([seed, i]))
            if p.n:
                sr, mst = summary_texts(p)
                rows.append([self.names.get(m, m), str(p.n), sr, mst, fmt(p.mst_success, 0)])
        return Table(
            f"{world}_default",
            f"{world} world, default point (95 % intervals)",
            ["algorithm", "n", "SR %", "mean time s", "of successes s"],
            rows,
            note=self.note,
        )

    def figures(self, df: Any, store: Any, out: Path, seed: int) -> list[Figure]:
        from odorloc.experiments import figures as F

        if not len(df):
            return []
        points, worlds = self.points(df), self._worlds()
        first = points[worlds[0].name]
        # one point per sweep draws no curve: the comparison figure shows it
        figs = (
            []
            if self.default_only
            else sweep_figures(
                first,
                worlds[0].sweeps,
                self._methods(worlds[0]),
                self.names,
                self.colors,
                seed,
                worlds[0].name,
                self.figure_files,
                self.limit,
                self.categorical,
            )
        )
        for w in [] if self.default_only else worlds[1:]:
            panels = [(f"{s.figure}: {s.xlabel}", s.values, s.setting, s.tick) for s in w.sweeps]
            title = f"Success against time, {w.name} world"

            def draw(
                p: Path, data: Points = points[w.name], panels=panels, title=title, w=w
            ) -> None:
                F.success_time_figure(
                    data, panels, self._methods(w), self.names, p, title, first, self.at, self.limit
                )

            figs.append(
                Figure(
                    w.curves or f"success_time_{w.name}.png",
                    f"{title} (solid) and {worlds[0].name} world (dashed)",
                    draw,
                )
            )
        if self.default_point is not None:
            every = self._every()
            rows = [
                (f"{w.name} world", points[w.name], self.default_point)
                for w in worlds
                if any(len(points[w.name].one(self.default_point, m)) for m in every)
            ]
            entries = [
                (m, textwrap.fill(self.names.get(m, m), 10), self.colors.get(m, "0.6"))
                for m in every
            ]

            def compare(p: Path) -> None:
                F.comparison_figure(
                    rows, entries, p, seed, "Default point (95 % intervals)", self.limit
                )

            if rows:
                figs.append(
                    Figure(
                        "comparison.png",
                        "Default point: success rate and mean time of every method",
                        compare,
                    )
                )
        return figs + self.extra_figures(df, points, seed)
