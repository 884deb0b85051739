"""A self-contained HTML report of a sweep.

The page has no external dependency: figures are embedded as base64 PNG (animations as base64
GIF), styles are inline, and a few lines of inline script switch the episode viewer's picker and
mark the body with what rendered (``data-rendered="images=5/5 tables=3
sections=settings,summary,..."``) so that a headless browser can check the page. It opens from
disk, offline.

Sections: the settings of the run (every scenario with its overrides, each searcher's resolved
parameters, root seed, episodes, odorloc version, machine, wall time), the per-cell summary with
intervals, paired comparisons between searchers, an optional comparison with a paper's reference
numbers, figures (success rates with Wilson intervals, success against time per cell,
localisation-error and energy distributions, success and time against every swept parameter,
search time per cell, success against start distance) and an episode viewer with a picker over
every kept episode.
"""

from __future__ import annotations

import base64
import html
import inspect
import io
import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from odorloc.experiments import stats
from odorloc.viz.intervals import errorbar_lengths

Renderer = Callable[[dict[str, np.ndarray], dict[str, Any]], Any]
"""``renderer(arrays, info) -> GIF bytes or a path to a GIF``; ``info`` holds the episode row."""

_CSS = """
body{font-family:system-ui,-apple-system,Segoe UI,Roboto,sans-serif;margin:24px auto;
max-width:1200px;color:#1b1f24;background:#fff;line-height:1.4}
h1{font-size:1.6em;margin-bottom:4px}h2{margin-top:32px;border-bottom:2px solid #e1e4e8;
padding-bottom:4px}.meta{color:#57606a;font-size:.9em}
table{border-collapse:collapse;margin:8px 0 16px 0;font-size:.86em}
th,td{border:1px solid #d0d7de;padding:4px 8px;text-align:right}
th{background:#f6f8fa}td.l,th.l{text-align:left}tr:nth-child(even) td{background:#fbfcfd}
.sig{font-weight:600;color:#0a6b2d}.bad{color:#b42318}
figure{display:inline-block;margin:8px 12px 16px 0;vertical-align:top}
figcaption{font-size:.85em;color:#57606a;max-width:560px}
img{border:1px solid #e1e4e8;max-width:100%;height:auto}.note{color:#57606a;font-style:italic}
pre{background:#f6f8fa;border:1px solid #e1e4e8;padding:6px 10px;font-size:.8em;
max-height:340px;overflow:auto;margin:4px 0}details{margin:4px 0 10px 0}
summary{cursor:pointer;color:#0b5cad}select{font-size:1em;padding:3px;max-width:100%}
.episode{margin-top:10px}
"""

_SCRIPT = """
function odorlocShow(key) {
  var eps = document.querySelectorAll('.episode');
  for (var i = 0; i < eps.length; i++) {
    eps[i].style.display = eps[i].getAttribute('data-key') === key ? 'block' : 'none';
  }
}
window.addEventListener('load', function () {
  var picker = document.getElementById('episode-picker');
  if (picker) {
    picker.addEventListener('change', function () { odorlocShow(picker.value); });
    odorlocShow(picker.value);
  }
  var imgs = document.images, ok = 0;
  for (var i = 0; i < imgs.length; i++) {
    if (imgs[i].complete && imgs[i].naturalWidth > 0) { ok++; }
  }
  var tables = document.getElementsByTagName('table').length;
  var heads = document.querySelectorAll('h2[id]'), ids = [];
  for (var j = 0; j < heads.length; j++) {
    if (heads[j].offsetHeight > 0) { ids.push(heads[j].id); }
  }
  var options = picker ? picker.options.length : 0;
  document.body.setAttribute('data-rendered',
    'images=' + ok + '/' + imgs.length + ' tables=' + tables + ' episodes=' + options +
    ' sections=' + ids.join(','));
});
"""


# ----------------------------------------------------------------------------- helpers


def _e(x: Any) -> str:
    return html.escape(str(x))


def _f(x: Any, digits: int = 1) -> str:
    try:
        v = float(x)
    except (TypeError, ValueError):
        return _e(x)
    return "–" if math.isnan(v) else f"{v:.{digits}f}"


def _p(p: float) -> str:
    if p is None or math.isnan(p):
        return "–"
    return "&lt;0.001" if p < 0.001 else f"{p:.3f}"


def _pct_ci(p: float, lo: float, hi: float) -> str:
    return f"{_f(100 * p)} [{_f(100 * lo)}, {_f(100 * hi)}]"


def _png(fig: Any) -> str:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=90, bbox_inches="tight")
    return base64.b64encode(buf.getvalue()).decode("ascii")


def _figure(fig: Any, caption: str) -> str:
    return (
        f'<figure><img alt="{_e(caption)}" src="data:image/png;base64,{_png(fig)}">'
        f"<figcaption>{_e(caption)}</figcaption></figure>"
    )


def _table(headers: Sequence[str], rows: Sequence[Sequence[str]], left: int = 1) -> str:
    th = "".join(
        f'<th class="{"l" if i < left else ""}">{_e(h)}</th>' for i, h in enumerate(headers)
    )
    body = "".join(
        "<tr>"
        + "".join(f'<td class="{"l" if i < left else ""}">{c}</td>' for i, c in enumerate(r))
        + "</tr>"
        for r in rows
    )
    return f"<table><thead><tr>{th}</tr></thead><tbody>{body}</tbody></table>"


def _new_fig(w: float = 6.0, h: float = 3.6) -> Any:
    # Figure without pyplot: no global state, no GUI backend
    from matplotlib.figure import Figure

    fig = Figure(figsize=(w, h))
    return fig


# ----------------------------------------------------------------------------- sections


def _summary_section(summ: Any, level: float) -> str:
    pct = f"{round(100 * level)} %"
    rows = []
    for r in summ.itertuples():
        rows.append(
            [
                _e(r.cell_id),
                str(r.n),
                _pct_ci(r.success_rate, r.success_lo, r.success_hi),
                f"{_f(r.mean_time)} [{_f(r.mean_time_lo)}, {_f(r.mean_time_hi)}]",
                f"{_f(r.median_time)} [{_f(r.median_time_lo)}, {_f(r.median_time_hi)}]",
                _f(r.mean_loc_error, 2),
                _f(r.mean_path_length, 1),
                f'<span class="bad">{r.errors}</span>' if r.errors else "0",
            ]
        )
    headers = [
        "cell",
        "n",
        f"success % [{pct} Wilson]",
        f"mean time s [{pct} bootstrap]",
        "median time s [CI]",
        "mean loc. error m",
        "mean path m",
        "errors",
    ]
    return (
        '<h2 id="summary">Summary per cell</h2>'
        '<p class="note">Times are over successful episodes; episodes that ended in an error are '
        "excluded from n and counted in the last column.</p>" + _table(headers, rows)
    )


MAX_AGENT_CELLS = 20
"""Cells shown in the per-agent section (the store keeps them all)."""


def _agent_long(df: Any, store: Any, source: Any) -> Any:
    """The per-agent values of the episodes of ``df`` as the long table (``cell_id, episode,
    agent, key, value``): the store's, else the ``agents`` column of ``df``, else the export
    beside ``source`` (``results_agents.csv`` beside ``results.csv``), else none."""
    import pandas as pd

    from odorloc.experiments.store import agent_table, agents_path

    if store is not None:
        long = store.agent_frame()
    elif "agents" in df.columns or not isinstance(source, str | Path):
        return agent_table(df)
    else:
        side = agents_path(source)
        if not side.is_file():
            return agent_table(df)
        long = pd.read_csv(side) if side.suffix == ".csv" else pd.read_parquet(side)
    keep = df[["cell_id", "episode"]].drop_duplicates()
    return long.merge(keep, on=["cell_id", "episode"], how="inner")


def _agent_section(df: Any, store: Any, source: Any = None) -> str:
    """Per-agent values (a team member's own counts and times), mean over each cell's
    episodes; empty when no episode has any."""
    from odorloc.experiments.display import agent_table

    long = _agent_long(df, store, source)
    if not len(long):
        return ""
    means = long.groupby(["cell_id", "agent", "key"], sort=False)["value"].mean()
    parts = [
        '<h2 id="agents">Per agent</h2><p class="note">Values that belong to one agent of a '
        "team (stored per agent beside the episode row), mean over the cell's episodes that "
        "have them.</p>"
    ]
    cells = list(dict.fromkeys(long["cell_id"]))
    for cell in cells[:MAX_AGENT_CELLS]:
        agents: dict[int, dict[str, float]] = {}
        for (_, a, k), v in means.loc[[cell]].items():
            agents.setdefault(int(a), {})[str(k)] = float(v)
        headers, rows = agent_table(agents)
        parts.append(f"<h3>{_e(cell)}</h3>" + _table(headers, [[_e(c) for c in r] for r in rows]))
    if len(cells) > MAX_AGENT_CELLS:
        parts.append(f'<p class="note">{len(cells) - MAX_AGENT_CELLS} more cells not shown.</p>')
    return "".join(parts)


def _paired_section(df: Any, level: float, seed: int) -> str:
    comp = stats.compare_searchers(df, level=level, seed=seed)
    if len(comp) == 0:
        return ""
    rows = []
    for (wk, a, b), g in comp.groupby(["world_key", "cell_a", "cell_b"], sort=False):
        s = g[g["metric"] == "success"].iloc[0]
        t = g[g["metric"] == "search_time"].iloc[0]
        sig_s = ' class="sig"' if s.p_value < 0.05 else ""
        sig_t = ' class="sig"' if t.p_value < 0.05 else ""
        rows.append(
            [
                _e(wk),
                # a world key may itself hold "/" (a scenario file's path)
                _e(a.removeprefix(f"{wk}/")),
                _e(b.removeprefix(f"{wk}/")),
                str(s.n_pairs),
                f"{_f(100 * s.mean_diff)} [{_f(100 * s.diff_lo)}, {_f(100 * s.diff_hi)}]",
                f"<span{sig_s}>{_p(s.p_value)}</span>",
                str(t.n_pairs),
                f"{_f(t.mean_diff)} [{_f(t.diff_lo)}, {_f(t.diff_hi)}]",
                f"<span{sig_t}>{_p(t.p_value)}</span>",
            ]
        )
    headers = [
        "world",
        "A",
        "B",
        "pairs",
        "success A−B (points) [CI]",
        "McNemar p",
        "pairs",
        "time A−B s [CI]",
        "Wilcoxon p",
    ]
    return (
        '<h2 id="paired">Paired comparisons</h2>'
        '<p class="note">Episode i of every searcher faced the same world, so differences are '
        "paired by episode. Success differences have Newcombe's interval for paired proportions. "
        "Time differences use every episode without error, a failure at the time it ended (the "
        "time limit, or earlier when a searcher got stuck or declared wrongly): read them beside "
        "the success difference.</p>" + _table(headers, rows, left=3)
    )


def _finite_or_none(v: Any) -> float | None:
    """A paper's number, or ``None`` where it gives none (``None`` or NaN)."""
    if v is None:
        return None
    v = float(v)
    return v if math.isfinite(v) else None


def paper_section(summ: Any, reference: Mapping[str, Mapping[str, Any]]) -> str:
    rows = []
    for key, ref in reference.items():
        match = summ[(summ["cell_id"] == key) | (summ["searcher"] == key)]
        if len(match) == 0:
            rows.append([_e(key), _e(ref.get("source", "")), "–", "–", "–", "–", "no such cell"])
            continue
        for r in match.itertuples():
            ps = _finite_or_none(ref.get("success_rate"))
            pt = _finite_or_none(ref.get("mean_time"))
            in_s = ps is not None and r.success_lo <= ps <= r.success_hi
            no_time = math.isnan(r.mean_time_lo)
            in_t = pt is not None and not no_time and r.mean_time_lo <= pt <= r.mean_time_hi
            verdict = []
            if ps is not None:
                verdict.append("success within CI" if in_s else "success outside CI")
            if pt is not None:
                # no interval (no success to time) is no evidence either way
                verdict.append(
                    "no time to compare"
                    if no_time
                    else "time within CI"
                    if in_t
                    else "time outside CI"
                )
            rows.append(
                [
                    _e(r.cell_id),
                    _e(ref.get("source", "")),
                    _f(100 * ps) if ps is not None else "–",
                    _pct_ci(r.success_rate, r.success_lo, r.success_hi),
                    _f(pt) if pt is not None else "–",
                    f"{_f(r.mean_time)} [{_f(r.mean_time_lo)}, {_f(r.mean_time_hi)}]",
                    _e("; ".join(verdict)),
                ]
            )
    headers = [
        "cell",
        "paper source",
        "paper success %",
        "ours [CI]",
        "paper time s",
        "ours [CI]",
        "verdict",
    ]
    return (
        '<h2 id="paper">Comparison with the paper</h2>'
        '<p class="note">Our simulator is not the paper\'s: the ordering of methods and the '
        "ballpark matter more than exact agreement.</p>" + _table(headers, rows, left=2)
    )


def _group_label(row: Any, exclude: str, swept: Sequence[str]) -> str:
    parts = [str(row["searcher"])]
    parts += [f"{c.split('.', 1)[1]}={row[c]}" for c in swept if c != exclude]
    return " ".join(parts)


def _param_figures(summ: Any, level: float) -> list[str]:
    swept = [c for c in summ.columns if c.startswith(("scenario.", "searcher."))]
    out = []
    for col in swept:
        vals = summ[col]
        if vals.nunique(dropna=True) < 2:
            continue
        numeric = all(isinstance(v, int | float) and not isinstance(v, bool) for v in vals)
        fig = _new_fig(10.0, 3.6)
        ax1, ax2 = fig.subplots(1, 2)
        labels = summ.apply(lambda r, col=col: _group_label(r, col, swept), axis=1)
        cats = list(dict.fromkeys(str(v) for v in vals))
        for lab, g in summ.groupby(labels, sort=False):
            x = (
                g[col].to_numpy(float)
                if numeric
                else np.array([cats.index(str(v)) for v in g[col]])
            )
            o = np.argsort(x)
            x = x[o]
            sr = g["success_rate"].to_numpy(float)[o]
            lo = g["success_lo"].to_numpy(float)[o]
            hi = g["success_hi"].to_numpy(float)[o]
            ax1.errorbar(
                x,
                100 * sr,
                yerr=errorbar_lengths(100 * sr, 100 * lo, 100 * hi),
                marker="o",
                capsize=3,
                label=lab,
            )
            mt = g["mean_time"].to_numpy(float)[o]
            tlo = g["mean_time_lo"].to_numpy(float)[o]
            thi = g["mean_time_hi"].to_numpy(float)[o]
            ax2.errorbar(
                x, mt, yerr=errorbar_lengths(mt, tlo, thi), marker="o", capsize=3, label=lab
            )
        name = col.split(".", 1)[1]
        for ax in (ax1, ax2):
            ax.set_xlabel(name)
            ax.grid(alpha=0.3)
            if not numeric:
                ax.set_xticks(range(len(cats)), cats)
        ax1.set_ylabel("success %")
        ax1.set_ylim(-3, 103)
        ax2.set_ylabel("mean search time, s")
        ax1.legend(fontsize=7)
        pct = round(100 * level)
        out.append(
            _figure(
                fig,
                f"Success rate (Wilson {pct} % CI) and mean search time "
                f"(bootstrap {pct} % CI) against {name}.",
            )
        )
    return out


#: Cells beyond which the box plot is left out (one row per cell would be unreadable; the
#: summary table has every cell).
MAX_BOX_CELLS = 60


#: Configurations beyond which the success-against-distance figure is left out.
MAX_CURVES = 12


def _box_figure(df: Any) -> str | None:
    ran = df[df["status"] != "error"]
    ok = ran[ran["success"].fillna(False).astype(bool)]
    # every cell keeps its row, so that a cell without a success shows as one
    cells = list(dict.fromkeys(ran["cell_id"]))
    if len(ok) == 0 or len(cells) > MAX_BOX_CELLS:
        return None
    times = {c: g.dropna().to_numpy(float) for c, g in ok.groupby("cell_id")["search_time"]}
    data = [times.get(c, np.zeros(0)) for c in cells]
    fig = _new_fig(7.5, max(2.5, 0.35 * len(cells) + 1.2))
    ax = fig.subplots()
    # horizontal boxes: long cell labels read along the axis instead of crowding it
    pos = np.arange(len(cells), 0, -1)
    if "orientation" in inspect.signature(ax.boxplot).parameters:
        ax.boxplot(data, positions=pos, showmeans=True, orientation="horizontal")
    else:  # matplotlib < 3.10
        ax.boxplot(data, positions=pos, showmeans=True, vert=False)
    ax.set_yticks(pos, cells, fontsize=7)
    for y, d in zip(pos, data, strict=True):
        if d.size == 0:
            ax.text(
                0.01,
                y,
                "no success",
                transform=ax.get_yaxis_transform(),
                va="center",
                fontsize=7,
                color="#b42318",
            )
    ax.set_xlabel("search time, s")
    ax.grid(axis="x", alpha=0.3)
    return _figure(
        fig, "Search time of successful episodes per cell (box: quartiles; triangle: mean)."
    )


def _distance_figure(df: Any, level: float, bins: int = 5) -> str | None:
    ok = df[(df["status"] != "error")].dropna(subset=["start_distance"])
    if len(ok) < 2 * bins or ok["start_distance"].nunique() < 2:
        return None
    d = ok["start_distance"].to_numpy(float)
    edges = np.unique(np.quantile(d, np.linspace(0, 1, bins + 1)))
    if edges.size < 3:
        return None
    fig = _new_fig(6.5, 3.8)
    ax = fig.subplots()
    # One curve per configuration (scenario, searcher and every swept setting but the start):
    # start distance is what varies along it
    keys = [c for c in ("scenario", "searcher") if c in ok.columns] or ["cell_id"]
    swept = [
        c
        for c in ok.columns
        if c.startswith(("scenario.", "searcher."))
        and not c.split(".", 1)[1].startswith(("start_", "agents."))
        and ok[c].nunique(dropna=False) > 1
    ]
    groups = ok.groupby(keys + swept, sort=False, dropna=False)
    if groups.ngroups > MAX_CURVES:
        return None  # a legend of dozens of configurations reads as nothing
    for lab, g in groups:
        parts = lab if isinstance(lab, tuple) else (lab,)
        lab = " / ".join(map(str, parts[: len(keys)]))
        lab += "".join(
            f" {c.split('.', 1)[1]}={v}" for c, v in zip(swept, parts[len(keys) :], strict=True)
        )
        gd = g["start_distance"].to_numpy(float)
        gs = g["success"].fillna(False).astype(bool).to_numpy()
        idx = np.clip(np.searchsorted(edges, gd, side="right") - 1, 0, edges.size - 2)
        n = np.bincount(idx, minlength=edges.size - 1)
        k = np.bincount(idx, weights=gs, minlength=edges.size - 1)
        keep = n > 0
        centres = 0.5 * (edges[:-1] + edges[1:])[keep]
        lo, hi = stats.wilson_interval(k[keep], n[keep], level)
        p = k[keep] / n[keep]
        ax.errorbar(
            centres,
            100 * p,
            yerr=errorbar_lengths(100 * p, 100 * lo, 100 * hi),
            marker="o",
            capsize=3,
            label=lab,
        )
    ax.set_xlabel("start distance to source, m")
    ax.set_ylabel("success %")
    ax.set_ylim(-3, 103)
    ax.grid(alpha=0.3)
    # beside the axes: a legend inside would hide curves (and with long labels, the axes)
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0)
    return _figure(
        fig,
        f"Success rate against start distance (quantile bins, Wilson {round(100 * level)} % CI).",
    )


def _trajectory_png(arrays: Mapping[str, np.ndarray], info: Mapping[str, Any]) -> str:
    """A stored episode's trajectory figure (the one ``odorloc run`` writes) when its arrays
    are a recording; a plain path plot for other arrays."""
    if "arena_bounds" in arrays and "meta" in arrays:
        from odorloc.engine.recorder import Recording
        from odorloc.viz.episode import plot_trajectory

        rec = Recording.from_arrays(dict(arrays))
        rec.meta.update({k: v for k, v in info.items() if isinstance(v, str | int | float | bool)})
        fig = plot_trajectory(rec)
        try:
            return _png(fig)
        finally:
            import matplotlib.pyplot as plt

            plt.close(fig)
    pos = np.asarray(arrays["positions"], float)
    # (T, d) for one agent or (T, agents, d) for a team
    tracks = [pos[:, i, :2] for i in range(pos.shape[1])] if pos.ndim == 3 else [pos[:, :2]]
    fig = _new_fig(4.2, 4.0)
    ax = fig.subplots()
    for i, tr in enumerate(tracks):
        ax.plot(tr[:, 0], tr[:, 1], lw=1.2, label="path" if i == 0 else None)
        ax.plot(tr[0, 0], tr[0, 1], "o", color="tab:green", ms=6, label="start" if i == 0 else None)
        ax.plot(tr[-1, 0], tr[-1, 1], "s", color="tab:blue", ms=5, label="end" if i == 0 else None)
    for key in ("declared", "estimate"):
        if key in arrays and np.size(arrays[key]):
            est = np.atleast_2d(np.asarray(arrays[key], float))
            ax.plot(
                est[:, 0], est[:, 1], "o", mfc="none", mec="magenta", mew=2, ms=16, zorder=8,
                label="declared",
            )  # fmt: skip
            break
    for key in ("sources", "source"):
        if key in arrays and np.size(arrays[key]):
            src = np.atleast_2d(np.asarray(arrays[key], float))
            # above the declaration: a declared marker never hides the true source
            ax.plot(
                src[:, 0], src[:, 1], "*", color="gold", mec="k", ms=14, zorder=9, label="source"
            )
            break
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x, m")
    ax.set_ylabel("y, m")
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1.0))
    ax.grid(alpha=0.3)
    return _png(fig)


def _task_end(cell: Any, cache: dict[str, str | None]) -> str | None:
    """``task.end`` of a stored cell's scenario (``None`` when it cannot be read here)."""
    import json

    if not isinstance(cell, str) or not cell:
        return None
    if cell not in cache:
        try:
            from odorloc.experiments.runner import cell_scenario

            cache[cell] = cell_scenario(json.loads(cell)).task.end
        except Exception:  # a scenario file that is not here any more: no task to name
            cache[cell] = None
    return cache[cell]


MAX_VIEWER = 100
"""Most kept episodes the viewer's picker offers (the first ones, by cell and episode): each
is one still figure, drawn when the report is written."""

MAX_ANIMATED = 4
"""Most viewer episodes that also get an animation (the rest show their still figure)."""


def _viewer_section(
    df: Any,
    store: Any,
    episodes: Sequence[tuple[str, int]] | None,
    renderer: Renderer | None,
) -> str:
    head = '<h2 id="viewer">Episode viewer</h2>'
    if episodes is None:
        if store is None:
            return ""
        episodes = store.episodes_with_arrays()
        if not episodes:
            return (
                head + '<p class="note">No episode of this run kept its trajectory: set '
                "<code>keep_arrays: true</code> or <code>keep_episodes: [0, ...]</code> in the "
                "sweep file to see episodes here.</p>"
            )
    if not episodes:
        return ""
    episodes = list(episodes)
    parts = [head]
    if len(episodes) > MAX_VIEWER:
        parts.append(
            f'<p class="note">{len(episodes)} episodes were kept; the picker offers the first '
            f"{MAX_VIEWER} (by cell and episode).</p>"
        )
        episodes = episodes[:MAX_VIEWER]
    options = []
    items = []
    ends: dict[str, str | None] = {}
    for i, (cid, ep) in enumerate(episodes):
        key = f"e{i}"
        sel = df[(df["cell_id"] == cid) & (df["episode"] == ep)]
        info = sel.iloc[0].to_dict() if len(sel) else {"cell_id": cid, "episode": ep}
        caption = f"{cid}, episode {ep}"
        if len(sel):
            from odorloc.experiments.display import explain_failure, format_metric

            caption += (
                f": {info.get('termination', '')}, success={bool(info.get('success'))}, "
                f"search time {format_metric('search_time', info.get('search_time'), True)}"
            )
            why = explain_failure(info, end=_task_end(info.get("cell"), ends))
            if why:
                caption += f"; {why}"
        options.append(f'<option value="{key}">{_e(cid)}, episode {ep}</option>')
        try:
            arrays = store.arrays(cid, ep) if store is not None else None
        except Exception as exc:  # one unreadable blob is reported, the rest still shows
            items.append(
                f'<div class="episode" data-key="{key}"><p class="note bad">{_e(caption)}: '
                f"stored arrays unreadable ({_e(type(exc).__name__)}: {_e(exc)})</p></div>"
            )
            continue
        imgs = []
        if arrays is not None and renderer is not None and i < MAX_ANIMATED:
            try:
                gif = renderer(arrays, info)
                if isinstance(gif, str | Path):
                    gif = Path(gif).read_bytes()
                if gif:  # a renderer may decline (None) and leave the still figure
                    b64 = base64.b64encode(gif).decode()
                    imgs.append(f'<img alt="{_e(caption)}" src="data:image/gif;base64,{b64}">')
            except Exception as exc:  # the still figure still tells the story
                caption += f" (animation failed: {type(exc).__name__}: {exc})"
        if not imgs and arrays is not None and "positions" in arrays:
            try:
                png = _trajectory_png(arrays, info)
                imgs.append(f'<img alt="{_e(caption)}" src="data:image/png;base64,{png}">')
            except Exception as exc:  # malformed arrays: say so, keep the page
                caption += f" (trajectory plot failed: {type(exc).__name__}: {exc})"
        if not imgs:
            body = f'<p class="note">{_e(caption)}: no trajectory stored.</p>'
        else:
            body = f"<figure>{''.join(imgs)}<figcaption>{_e(caption)}</figcaption></figure>"
        items.append(f'<div class="episode" data-key="{key}">{body}</div>')
    parts.append(
        f'<p><label for="episode-picker">Episode ({len(episodes)} kept): </label>'
        f'<select id="episode-picker">{"".join(options)}</select></p>'
    )
    parts += items
    return "".join(parts)


# ----------------------------------------------------------------------------- settings


def _kv(d: Mapping[str, Any]) -> str:
    return "; ".join(f"{k} = {_json_text(v)}" for k, v in d.items()) or "–"


def _json_text(v: Any) -> str:
    import json

    return v if isinstance(v, str) else json.dumps(v, default=str)


def _yaml_text(d: Any) -> str:
    import yaml

    def plain(o: Any) -> Any:
        if isinstance(o, dict):
            return {str(k): plain(v) for k, v in o.items()}
        if isinstance(o, list | tuple):
            return [plain(v) for v in o]
        if isinstance(o, float) and not math.isfinite(o):
            return str(o)
        return o

    return yaml.safe_dump(plain(d), sort_keys=False, default_flow_style=None, width=96)


def _cells(df: Any) -> list[dict[str, Any]]:
    """The distinct cells of the rows (their stored cell JSON), in cell order."""
    import json

    if "cell" not in df.columns:
        return []
    out: dict[str, dict[str, Any]] = {}
    for cid, text in zip(df["cell_id"], df["cell"], strict=True):
        if cid not in out and isinstance(text, str) and text:
            try:
                out[cid] = json.loads(text)
            except ValueError:
                continue
    return [{"cell_id": k, **v} for k, v in out.items()]


def _resolved_searcher(cell: Mapping[str, Any]) -> dict[str, Any]:
    """The searcher's parameters as the cell ran them (defaults filled in); raises when the
    cell's scenario cannot be read here."""
    from odorloc.experiments.runner import cell_scenario

    sc = cell_scenario(dict(cell))
    return {"type": sc.searcher.type, **sc.searcher.params("searcher", "searcher").model_dump()}


MAX_SCENARIO_YAML = 12
"""Most world keys whose resolved scenario is shown (as YAML, folded)."""


def _settings_section(
    df: Any, meta: Mapping[str, str], runs: Sequence[Mapping[str, Any]], run_info: Mapping[str, Any]
) -> str:
    import json

    sweep: dict[str, Any] = {}
    if meta.get("sweep"):
        try:
            sweep = json.loads(meta["sweep"])
        except ValueError:
            sweep = {}
    cells = _cells(df)
    parts = ['<h2 id="settings">Settings</h2>']
    # --- the run
    per_cell = df.groupby("cell_id")["episode"].nunique() if len(df) else None
    stored = (
        f"{int(per_cell.min())}"
        + (f"-{int(per_cell.max())}" if per_cell.max() != per_cell.min() else "")
        if per_cell is not None and len(per_cell)
        else "0"
    )
    asked = run_info.get("episodes", sweep.get("episodes"))
    seed = run_info.get("seed", sweep.get("seed", "not recorded"))
    versions = sorted({str(r.get("odorloc_version")) for r in runs if r.get("odorloc_version")})
    machines = sorted({str(r.get("machine")) for r in runs if r.get("machine")})
    version = run_info.get("odorloc_version") or ", ".join(versions) or "not recorded"
    where = run_info.get("machine") or "; ".join(machines) or "not recorded"
    if "wall_time" in run_info:
        wall = f"{float(run_info['wall_time']):.1f} s"
    elif runs:
        total = sum(float(r.get("wall_time") or 0.0) for r in runs)
        wall = f"{total:.1f} s over {len(runs)} run{'s' if len(runs) > 1 else ''}"
    else:
        wall = "not recorded"
    compute = float(np.nansum(df["wall_time"].to_numpy(float))) if "wall_time" in df else math.nan
    rows = [
        ["sweep", _e(sweep.get("name") or run_info.get("name") or "–")],
        ["root seed", _e(seed)],
        [
            "episodes per cell",
            _e(f"{asked} asked, {stored} stored" if asked is not None else f"{stored} stored"),
        ],
        ["cells", str(df["cell_id"].nunique() if len(df) else 0)],
        ["odorloc version", _e(version)],
        ["machine", _e(where)],
        ["wall time", _e(wall)],
        ["episode compute time", _e(f"{compute:.1f} s (sum over episodes)")],
    ]
    for k in ("backend", "workers"):
        got = run_info.get(k) or sorted({str(r.get(k)) for r in runs if r.get(k) is not None})
        if got:
            rows.append([k, _e(got if isinstance(got, str | int) else ", ".join(got))])
    for k in ("config_hash", "created"):
        if meta.get(k):
            rows.append([k.replace("_", " "), _e(meta[k])])
    for r in runs:
        rows.append(
            [
                "run",
                _e(
                    f"{r.get('started', '?')}: {r.get('added', '?')} episode(s) added in "
                    f"{float(r.get('wall_time') or 0):.1f} s ({r.get('backend', '?')}, "
                    f"{r.get('workers', '?')} worker(s))"
                ),
            ]
        )
    parts.append(_table(["setting", "value"], rows, left=2))
    # --- scenarios with their overrides
    sc_rows = []
    if sweep.get("scenarios"):
        for sc in sweep["scenarios"]:
            sc_rows.append(
                [
                    _e(sc.get("label") or sc.get("name")),
                    _e(sc.get("name")),
                    _e(_kv(sc.get("params") or {})),
                    _e(_kv({k: f"{_json_text(v)}" for k, v in (sc.get("grid") or {}).items()})),
                    _e(_kv(sc.get("agent_grid") or {})),
                ]
            )
    else:
        seen: set[str] = set()
        for c in cells:
            key = json.dumps([c.get("scenario"), c.get("scenario_params")], sort_keys=True)
            if key in seen:
                continue
            seen.add(key)
            sc_rows.append(
                [
                    _e(c.get("scenario_label") or c.get("scenario")),
                    _e(c.get("scenario")),
                    _e(_kv(c.get("scenario_params") or {})),
                    "–",
                    "–",
                ]
            )
    if sc_rows:
        parts.append('<p class="meta">Scenarios and their overrides</p>')
        parts.append(
            _table(["scenario", "source", "overrides", "swept (grid)", "agent grid"], sc_rows, 5)
        )
    # --- the scenario of each world, as run
    worlds: dict[str, dict[str, Any]] = {}
    for c in cells:
        worlds.setdefault(c["cell_id"].rsplit("/", 1)[0], c)
    shown = list(worlds.items())[:MAX_SCENARIO_YAML]
    for wk, c in shown:
        try:
            from odorloc.experiments.runner import cell_scenario

            text = cell_scenario(c).to_yaml()
        except Exception as exc:  # a scenario file that is not here any more
            text = f"not readable here ({type(exc).__name__}: {exc})"
        parts.append(
            f"<details><summary>scenario {_e(wk)} as run</summary><pre>{_e(text)}</pre></details>"
        )
    if len(worlds) > len(shown):
        parts.append(f'<p class="note">{len(worlds) - len(shown)} more worlds not shown.</p>')
    # --- searchers with their resolved parameters
    by_label: dict[str, list[dict[str, Any]]] = {}
    for c in cells:
        by_label.setdefault(str(c.get("searcher_label") or c.get("searcher")), []).append(c)
    se_rows = []
    for label, group in by_label.items():
        resolved: list[dict[str, Any]] = []
        problem = ""
        for c in group:
            try:
                resolved.append(_resolved_searcher(c))
            except Exception as exc:
                problem = f"{type(exc).__name__}: {exc}"
                break
        if problem or not resolved:
            given = {"type": group[0].get("searcher"), **(group[0].get("searcher_params") or {})}
            text = _yaml_text(given) + f"# defaults not resolvable here ({problem})\n"
        else:
            merged: dict[str, Any] = {}
            for k, v in resolved[0].items():
                values = [json.dumps(r.get(k), sort_keys=True, default=str) for r in resolved]
                if len(set(values)) > 1:
                    distinct = list(dict.fromkeys(values))
                    merged[k] = f"varies by cell: {', '.join(distinct[:8])}" + (
                        " ..." if len(distinct) > 8 else ""
                    )
                else:
                    merged[k] = v
            text = _yaml_text(merged)
        se_rows.append(
            [
                _e(label),
                str(len(group)),
                f"<details><summary>{len(text.splitlines())} lines</summary>"
                f"<pre>{_e(text)}</pre></details>",
            ]
        )
    if se_rows:
        parts.append(
            '<p class="meta">Searchers and their parameters as run (defaults filled in; a '
            "parameter that differs between the cells of a searcher says so)</p>"
        )
        parts.append(_table(["searcher", "cells", "parameters"], se_rows, 3))
    return "".join(parts)


# ----------------------------------------------------------------------------- figures


def _cell_names(cells: Sequence[str]) -> list[str]:
    return [c if len(c) <= 48 else c[:22] + "..." + c[-23:] for c in cells]


def _success_rate_figure(summ: Any, level: float) -> str | None:
    if summ is None or len(summ) == 0 or len(summ) > MAX_BOX_CELLS:
        return None
    cells = list(summ["cell_id"])
    fig = _new_fig(7.5, max(2.4, 0.32 * len(cells) + 1.2))
    ax = fig.subplots()
    pos = np.arange(len(cells), 0, -1)
    p = 100 * summ["success_rate"].to_numpy(float)
    lo = 100 * summ["success_lo"].to_numpy(float)
    hi = 100 * summ["success_hi"].to_numpy(float)
    ax.errorbar(p, pos, xerr=errorbar_lengths(p, lo, hi), fmt="o", color="k", capsize=3)
    for y, n, k in zip(pos, summ["n"], summ["successes"], strict=True):
        ax.text(1.01, y, f"{k}/{n}", transform=ax.get_yaxis_transform(), va="center", fontsize=7)
    ax.set_yticks(pos, _cell_names(cells), fontsize=7)
    ax.set_xlim(-3, 103)
    ax.set_xlabel("success rate, %")
    ax.grid(axis="x", alpha=0.3)
    pct = round(100 * level)
    return _figure(
        fig,
        f"Success rate per cell with its Wilson {pct} % interval (right: successes / episodes).",
    )


def _success_time_figure(df: Any, level: float) -> str | None:
    ran = df[df["status"] != "error"]
    cells = list(dict.fromkeys(ran["cell_id"]))
    if not cells or len(cells) > MAX_CURVES:
        return None
    fig = _new_fig(7.5, 4.0)
    ax = fig.subplots()
    t_end = float(np.nanmax(ran["search_time"].to_numpy(float))) if len(ran) else 0.0
    if not math.isfinite(t_end) or t_end <= 0:
        return None
    grid = np.linspace(0.0, t_end, 200)
    for cid in cells:
        g = ran[ran["cell_id"] == cid]
        ok = g["success"].fillna(False).astype(bool).to_numpy()
        t = g["search_time"].to_numpy(float)
        # a failure never succeeds: its time is infinite
        when = np.where(ok & np.isfinite(t), t, np.inf)
        n = len(when)
        k = (when[None, :] <= grid[:, None]).sum(axis=1)
        lo, hi = stats.wilson_interval(k, np.full_like(k, n), level)
        (line,) = ax.step(grid, 100 * k / n, where="post", lw=1.3, label=f"{cid} (n={n})")
        ax.fill_between(grid, 100 * lo, 100 * hi, step="post", color=line.get_color(), alpha=0.15)
    ax.set_xlabel("search time, s")
    ax.set_ylabel("episodes succeeded by then, %")
    ax.set_ylim(-3, 103)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0)
    pct = round(100 * level)
    return _figure(
        fig,
        f"Success against time per cell: the share of episodes that had succeeded by each time "
        f"(failures never do), with pointwise Wilson {pct} % bands.",
    )


def _distribution_figure(df: Any) -> str | None:
    ran = df[df["status"] != "error"]
    cells = list(dict.fromkeys(ran["cell_id"]))
    if not cells or len(cells) > MAX_BOX_CELLS:
        return None
    # a metric never recorded (all missing, or all 0: a platform without an energy model) is
    # left out rather than drawn as one line at 0
    metrics = [
        (c, label)
        for c, label in (("loc_error", "localisation error, m"), ("energy", "energy, J"))
        if c in ran.columns and np.any(np.isfinite(v := ran[c].to_numpy(float)) & (v != 0.0))
    ]
    if not metrics:
        return None
    fig = _new_fig(4.6 * len(metrics) + 1.5, max(2.5, 0.35 * len(cells) + 1.2))
    axes = np.atleast_1d(fig.subplots(1, len(metrics), sharey=True))
    pos = np.arange(len(cells), 0, -1)
    for ax, (col, label) in zip(axes, metrics, strict=True):
        data = []
        for cid in cells:
            v = ran.loc[ran["cell_id"] == cid, col].to_numpy(float)
            data.append(v[np.isfinite(v)])
        shown = [d if d.size else np.array([np.nan]) for d in data]
        if "orientation" in inspect.signature(ax.boxplot).parameters:
            ax.boxplot(shown, positions=pos, showmeans=True, orientation="horizontal")
        else:  # matplotlib < 3.10
            ax.boxplot(shown, positions=pos, showmeans=True, vert=False)
        for y, d in zip(pos, data, strict=True):
            if d.size == 0:
                ax.text(0.01, y, "no value", transform=ax.get_yaxis_transform(), va="center",
                        fontsize=7, color="#b42318")  # fmt: skip
        ax.set_xlabel(label)
        ax.grid(axis="x", alpha=0.3)
        ax.ticklabel_format(axis="x", style="plain", useOffset=False)
    axes[0].set_yticks(pos, _cell_names(cells), fontsize=7)
    return _figure(
        fig,
        "Distributions per cell (box: quartiles; triangle: mean): "
        + " and ".join(
            "the localisation error of episodes with a declaration"
            if c == "loc_error"
            else "the energy used by every episode"
            for c, _ in metrics
        )
        + ".",
    )


def _failed(name: str, exc: Exception) -> str:
    return (
        f'<p class="note bad">The {_e(name)} could not be drawn from these results '
        f"({_e(type(exc).__name__)}: {_e(exc)}).</p>"
    )


def _guarded(name: str, fn: Callable[..., str], *args: Any) -> str:
    """A section, or a note saying why it is missing: one failing part never takes the rest of
    the report down."""
    try:
        return fn(*args)
    except Exception as exc:
        return _failed(name, exc)


# ----------------------------------------------------------------------------- entry points


@dataclass
class ReportSection:
    """An extra report section: a heading, text, tables and PNG figures.

    Attributes
    ----------
    title : str
    text : str
        A paragraph (plain text, escaped).
    tables : list of (caption, headers, rows)
        Rows of already formatted cells.
    figures : list of (path, caption)
        PNG (or GIF) files to embed.
    """

    title: str
    text: str = ""
    tables: list[tuple[str, Sequence[str], Sequence[Sequence[str]]]] = field(default_factory=list)
    figures: list[tuple[Path, str]] = field(default_factory=list)


def _extra_section(sec: ReportSection, index: int = 0) -> str:
    parts = [f'<h2 id="section-{index}">{_e(sec.title)}</h2>']
    if sec.text:
        parts.append(f"<p>{_e(sec.text)}</p>")
    for caption, headers, rows in sec.tables:
        if caption:
            parts.append(f'<p class="meta">{_e(caption)}</p>')
        parts.append(_table(list(headers), [[_e(c) for c in r] for r in rows]))
    for path, caption in sec.figures:
        try:
            data = base64.b64encode(Path(path).read_bytes()).decode()
        except OSError as exc:
            parts.append(f'<p class="note">figure {_e(Path(path).name)} unavailable: {_e(exc)}</p>')
            continue
        mime = "image/gif" if Path(path).suffix.lower() == ".gif" else "image/png"
        parts.append(
            f'<figure><img alt="{_e(caption)}" src="data:{mime};base64,{data}" '
            f'style="max-width:1150px"><figcaption>{_e(caption)}</figcaption></figure>'
        )
    return "".join(parts)


def write_report(
    store_or_df: Any,
    out_html: str | Path,
    *,
    title: str | None = None,
    reference: Mapping[str, Mapping[str, Any]] | None = None,
    episodes: Sequence[tuple[str, int]] | None = None,
    renderer: Renderer | None = None,
    level: float = 0.95,
    seed: int = 0,
    sections: Sequence[ReportSection] = (),
    paired: bool = True,
    success: str = "success",
    success_label: str = "",
    rows: Any = None,
    run_info: Mapping[str, Any] | None = None,
) -> Path:
    """Write a self-contained HTML report.

    Parameters
    ----------
    store_or_df : ResultStore, path or pandas.DataFrame
        Results: an open store, a store file, a CSV/Parquet export or an episode table.
    out_html : path
        Output file.
    title : str, optional
        Page title (default: the sweep name).
    reference : dict, optional
        Paper numbers per cell id or searcher label, e.g.
        ``{"pf-entropy": {"success_rate": 0.94, "mean_time": 110.0, "source": "Table 1"}}``.
    episodes : list of (cell_id, episode), optional
        Episodes the viewer's picker offers (default: every episode that kept its arrays, up
        to :data:`MAX_VIEWER`).
    renderer : callable, optional
        ``renderer(arrays, info) -> GIF bytes or path`` animating a stored episode, used for
        the first :data:`MAX_ANIMATED` episodes of the viewer; the others (and any it fails
        on) show their still trajectory figure.
    level : float
        Confidence level of every interval.
    seed : int
        Seed of the bootstrap.
    sections : sequence of ReportSection
        Extra sections shown first (a reproduction's key tables and figures).
    paired : bool
        Include the paired comparisons of every two cells of each world (``False`` for results
        with many cells per world whose paired tables are given in ``sections``).
    success : str
        Column that says whether an episode succeeded (default the episode's own
        ``success``); a reproduction whose paper scores episodes differently names its column
        here, so that every table of the page (and the console) counts the same thing.
    success_label : str
        What ``success`` means, shown under the title.
    rows : pandas.DataFrame, optional
        The episodes to report when they are a subset of the store's (a reproduction run with
        fewer episodes than the store holds); the store still provides the stored arrays.
    run_info : dict, optional
        Facts of the run for the settings section where the store does not hold them (a
        reproduction of several stores): ``seed``, ``episodes``, ``wall_time`` (s),
        ``odorloc_version``, ``machine``, ``backend``, ``workers``, ``name``.

    Returns
    -------
    pathlib.Path
        ``out_html``.
    """
    import pandas as pd

    from odorloc.experiments.store import ResultStore, open_results

    store = None
    own = False
    if isinstance(store_or_df, ResultStore):
        store = store_or_df
    elif isinstance(store_or_df, str | Path) and Path(store_or_df).suffix not in (
        ".csv",
        ".parquet",
        ".pq",
    ):
        store = ResultStore(store_or_df, readonly=True)
        own = True
    try:
        if rows is not None:
            df = rows
        else:
            df = store.frame() if store is not None else open_results(store_or_df)
        if success != "success" and len(df):
            df = df.copy()
            # rows without the column (failed episodes) did not meet the criterion
            col = df[success] if success in df.columns else False
            df["success"] = pd.Series(col, index=df.index).astype("boolean").fillna(False)
        meta = store.meta() if store is not None else {}
        runs = store.runs() if store is not None else []
        sweep_name = ""
        if meta.get("sweep"):
            import json

            sweep_name = json.loads(meta["sweep"]).get("name", "")
        title = title or (
            f"odorloc sweep report: {sweep_name}" if sweep_name else "odorloc sweep report"
        )
        try:
            summ = stats.summarize(df, level=level, seed=seed) if len(df) else None
        except Exception:  # each section that needs it says so below
            summ = None
        n_err = int((df["status"] == "error").sum()) if len(df) else 0
        n_cells = df["cell_id"].nunique() if len(df) else 0
        body = [
            f"<h1>{_e(title)}</h1>",
            f'<p class="meta">{len(df)} episodes in {n_cells} cells; '
            f"{n_err} errors; config hash {_e(meta.get('config_hash', '–'))}; "
            f"generated {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}.</p>",
        ]
        if success_label:
            body.append(f'<p class="meta">Success: {_e(success_label)}</p>')
        body.append(_guarded("settings", _settings_section, df, meta, runs, run_info or {}))
        for i, sec in enumerate(sections):
            body.append(_guarded(f"section {sec.title!r}", _extra_section, sec, i))
        if len(df) == 0:
            body.append('<p class="note">No episodes stored yet.</p>')
        else:
            body.append(_guarded("summary", _summary_section, summ, level))
            if paired:
                body.append(_guarded("paired comparisons", _paired_section, df, level, seed))
            if reference:
                body.append(_guarded("paper comparison", paper_section, summ, reference))
            figs: list[str] = []
            for name, fn, args in (
                ("success-rate figure", _success_rate_figure, (summ, level)),
                ("success-against-time figure", _success_time_figure, (df, level)),
                ("distributions figure", _distribution_figure, (df,)),
                ("parameter figures", _param_figures, (summ, level)),
                ("search-time box plot", _box_figure, (df,)),
                ("start-distance figure", _distance_figure, (df, level)),
            ):
                try:
                    got = fn(*args)
                except Exception as exc:
                    figs.append(_failed(name, exc))
                    continue
                figs += got if isinstance(got, list) else [got] if got else []
            if figs:
                body.append('<h2 id="figures">Figures</h2>' + "".join(figs))
            body.append(_guarded("per-agent values", _agent_section, df, store, store_or_df))
            body.append(_guarded("episode viewer", _viewer_section, df, store, episodes, renderer))
            errs = df[df["status"] == "error"]
            if len(errs):
                rows = [
                    [
                        _e(r.cell_id),
                        str(r.episode),
                        _e(str(r.error).splitlines()[0] if r.error else ""),
                    ]
                    for r in errs.head(50).itertuples()
                ]
                body.append(
                    '<h2 id="errors">Errors</h2>'
                    + _table(["cell", "episode", "error"], rows, left=3)
                )
    finally:
        if own and store is not None:
            store.close()
    page = (
        '<!DOCTYPE html><html lang="en"><head><meta charset="utf-8">'
        f"<title>{_e(title)}</title><style>{_CSS}</style></head><body>"
        + "\n".join(body)
        + f"<script>{_SCRIPT}</script></body></html>"
    )
    out = Path(out_html)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(page, encoding="utf-8")
    return out


def _default_renderer() -> Renderer | None:
    try:
        from odorloc.viz.animation import episode_gif  # type: ignore[import-not-found]
    except ImportError:
        return None
    return episode_gif


def report_main(results_path: str | Path, out_html: str | Path, **kw: Any) -> Path:
    """Command-line entry: report on a results store (or CSV/Parquet export).

    The package's episode animation (``odorloc.viz.animation.episode_gif``) is used for the
    episode viewer when available.
    """
    from odorloc.core.errors import ConfigError

    p = Path(results_path)
    if not p.exists():
        raise ConfigError("results", f"no such file: {p}")
    kw.setdefault("renderer", _default_renderer())
    return write_report(p, out_html, **kw)
