"""A self-contained HTML report of a sweep.

The page has no external dependency: figures are embedded as base64 PNG (animations as base64
GIF), styles are inline, and a few lines of inline script only mark the body with what rendered
(``data-rendered="images=5/5 tables=3"``) so that a headless browser can check the page. It opens
from disk, offline.

Sections: per-cell summary with intervals, paired comparisons between searchers, an optional
comparison with a paper's reference numbers, standard figures (success and time against every
swept parameter, box plots of search time, success against start distance) and an episode viewer.
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
"""

_SCRIPT = """
window.addEventListener('load', function () {
  var imgs = document.images, ok = 0;
  for (var i = 0; i < imgs.length; i++) {
    if (imgs[i].complete && imgs[i].naturalWidth > 0) { ok++; }
  }
  var tables = document.getElementsByTagName('table').length;
  document.body.setAttribute('data-rendered',
    'images=' + ok + '/' + imgs.length + ' tables=' + tables);
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
        "<h2>Summary per cell</h2>"
        '<p class="note">Times are over successful episodes; episodes that ended in an error are '
        "excluded from n and counted in the last column.</p>" + _table(headers, rows)
    )


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
        "<h2>Paired comparisons</h2>"
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
        "<h2>Comparison with the paper</h2>"
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


def _trajectory_png(arrays: Mapping[str, np.ndarray]) -> str:
    pos = np.asarray(arrays["positions"], float)
    # (T, d) for one agent or (T, agents, d) for a team
    tracks = [pos[:, i, :2] for i in range(pos.shape[1])] if pos.ndim == 3 else [pos[:, :2]]
    fig = _new_fig(4.2, 4.0)
    ax = fig.subplots()
    for i, tr in enumerate(tracks):
        ax.plot(tr[:, 0], tr[:, 1], lw=1.2, label="path" if i == 0 else None)
        ax.plot(tr[0, 0], tr[0, 1], "o", color="tab:green", ms=6, label="start" if i == 0 else None)
        ax.plot(tr[-1, 0], tr[-1, 1], "s", color="tab:blue", ms=5, label="end" if i == 0 else None)
    for key in ("sources", "source"):
        if key in arrays and np.size(arrays[key]):
            src = np.atleast_2d(np.asarray(arrays[key], float))
            ax.plot(src[:, 0], src[:, 1], "*", color="tab:red", ms=14, label="source")
            break
    for key in ("declared", "estimate"):
        if key in arrays and np.size(arrays[key]):
            est = np.atleast_2d(np.asarray(arrays[key], float))
            ax.plot(est[:, 0], est[:, 1], "x", color="k", ms=9, label="declared")
            break
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x, m")
    ax.set_ylabel("y, m")
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3)
    return _png(fig)


def _viewer_section(
    df: Any,
    store: Any,
    episodes: Sequence[tuple[str, int]] | None,
    renderer: Renderer | None,
) -> str:
    if episodes is None:
        if store is None:
            return ""
        chosen: list[tuple[str, int]] = []
        seen: set[str] = set()
        for cid, ep in store.episodes_with_arrays():
            if cid not in seen:
                seen.add(cid)
                chosen.append((cid, ep))
            if len(chosen) >= 4:
                break
        episodes = chosen
        if not episodes:
            return (
                "<h2>Episode viewer</h2>"
                '<p class="note">No episode of this run kept its trajectory: set '
                "<code>keep_arrays: true</code> or <code>keep_episodes: [0, ...]</code> in the "
                "sweep file to see episodes here.</p>"
            )
    if not episodes:
        return ""
    parts = ["<h2>Episode viewer</h2>"]
    for cid, ep in episodes:
        sel = df[(df["cell_id"] == cid) & (df["episode"] == ep)]
        info = sel.iloc[0].to_dict() if len(sel) else {"cell_id": cid, "episode": ep}
        caption = f"{cid}, episode {ep}"
        if len(sel):
            caption += (
                f": {info.get('termination', '')}, success={bool(info.get('success'))}, "
                f"t={_f(info.get('search_time'))} s"
            )
        try:
            arrays = store.arrays(cid, ep) if store is not None else None
        except Exception as exc:  # one unreadable blob is reported, the rest still shows
            parts.append(
                f'<p class="note bad">{_e(caption)}: stored arrays unreadable '
                f"({_e(type(exc).__name__)}: {_e(exc)})</p>"
            )
            continue
        img = None
        if arrays is not None and renderer is not None:
            try:
                gif = renderer(arrays, info)
                if isinstance(gif, str | Path):
                    gif = Path(gif).read_bytes()
                if gif:  # a renderer may decline (None) and leave the static plot
                    b64 = base64.b64encode(gif).decode()
                    img = f'<img alt="{_e(caption)}" src="data:image/gif;base64,{b64}">'
            except Exception as exc:  # the static plot still tells the story
                caption += f" (animation failed: {type(exc).__name__}: {exc})"
        if img is None and arrays is not None and "positions" in arrays:
            try:
                png = _trajectory_png(arrays)
                img = f'<img alt="{_e(caption)}" src="data:image/png;base64,{png}">'
            except Exception as exc:  # malformed arrays: say so, keep the page
                caption += f" (trajectory plot failed: {type(exc).__name__}: {exc})"
        if img is None:
            parts.append(f'<p class="note">{_e(caption)}: no trajectory stored.</p>')
        else:
            parts.append(f"<figure>{img}<figcaption>{_e(caption)}</figcaption></figure>")
    return "".join(parts)


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


def _extra_section(sec: ReportSection) -> str:
    parts = [f"<h2>{_e(sec.title)}</h2>"]
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
        Episodes to show in the viewer (default: the first stored trajectory of up to four cells).
    renderer : callable, optional
        ``renderer(arrays, info) -> GIF bytes or path`` animating a stored episode; without it
        (or if it fails) a static trajectory plot is embedded.
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
        for sec in sections:
            body.append(_guarded(f"section {sec.title!r}", _extra_section, sec))
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
                body.append("<h2>Figures</h2>" + "".join(figs))
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
                body.append("<h2>Errors</h2>" + _table(["cell", "episode", "error"], rows, left=3))
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
