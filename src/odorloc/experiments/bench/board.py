"""The HTML leaderboard and its figures, and the console and Markdown tables of the board.

``leaderboard.html`` is one self-contained page: the overall board, then one table per task
(sortable by clicking a column head, with a few lines of inline script), each cell linking to
the figure of its metric (``figures/<task>-<metric>.png``: every method's value with its 95 %
interval, drawn with :func:`odorloc.viz.intervals.bars_with_intervals`).
"""

from __future__ import annotations

import html
import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

__all__ = ["draw_figures", "markdown_board", "text_board", "write_leaderboard"]

#: Board columns: metric -> (heading, unit, scale, digits).
COLUMNS: dict[str, tuple[str, str, float, int]] = {
    "success": ("success", "%", 100.0, 0),
    "search_time": ("search time", "s", 1.0, 1),
    "path_ratio": ("path / distance", "", 1.0, 2),
    "loc_error": ("loc. error", "m", 1.0, 2),
    "emd": ("EMD", "m", 1.0, 2),
    "rate_error": ("rate error", "x", 1.0, 2),
    "energy": ("energy", "kJ", 1e-3, 1),
    "bytes": ("bytes", "kB", 1e-3, 1),
    "cpu_ms_per_decision": ("CPU/decision", "ms", 1.0, 2),
}


def _columns(task: Mapping[str, Any]) -> list[str]:
    base = ["success", "search_time", "path_ratio", "loc_error"]
    return [*base, *task.get("metrics", []), "cpu_ms_per_decision"]


def _fmt(row: Mapping[str, Any], metric: str, interval: bool = True) -> str:
    v = row.get(metric)
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "-"
    _, _, scale, digits = COLUMNS[metric]
    text = f"{v * scale:.{digits}f}"
    lo, hi = row.get(f"{metric}_lo"), row.get(f"{metric}_hi")
    if interval and lo is not None and hi is not None:
        text += f" [{lo * scale:.{digits}f}, {hi * scale:.{digits}f}]"
    return text


def _failures(row: Mapping[str, Any]) -> str:
    return ", ".join(f"{k} {n}" for k, n in row.get("failures", {}).items()) or "-"


def draw_figures(doc: Mapping[str, Any], folder: Path) -> dict[tuple[str, str], str]:
    """One figure per task and metric: ``{(task, metric): relative path}``."""
    from odorloc.viz.backend import pyplot
    from odorloc.viz.intervals import bars_with_intervals

    plt = pyplot()
    folder.mkdir(parents=True, exist_ok=True)
    out: dict[tuple[str, str], str] = {}
    for task in doc["tasks"]:
        rows = [r for r in doc["rows"] if r["task"] == task["name"]]
        if not rows:
            continue
        for metric in _columns(task):
            vals = [r.get(metric) for r in rows]
            if all(v is None for v in vals):
                continue
            head, unit, scale, _ = COLUMNS[metric]

            def scaled(
                key: str, rows: Sequence[Mapping[str, Any]] = rows, scale: float = scale
            ) -> list[float]:
                return [math.nan if r.get(key) is None else r[key] * scale for r in rows]

            fig, ax = plt.subplots(figsize=(6.4, 0.9 + 0.28 * len(rows)))
            y = list(range(len(rows)))
            bars_with_intervals(
                ax,
                y,
                scaled(metric),
                scaled(f"{metric}_lo"),
                scaled(f"{metric}_hi"),
                horizontal=True,
                color="#4c78a8",
            )
            ref = (task.get("reference") or {}).get(metric) or {}
            marks = [(i, ref[r["method"]]) for i, r in enumerate(rows) if r["method"] in ref]
            if marks:
                ax.errorbar(
                    [m[0] * scale for _, m in marks],
                    [i for i, _ in marks],
                    xerr=[1.96 * m[1] * scale for _, m in marks],
                    fmt="o",
                    color="#d62728",
                    ms=4,
                    capsize=2,
                    lw=1.0,
                    label="published",
                )
                ax.legend(fontsize=7, loc="upper right")
            ax.set_yticks(y, [r["method"] for r in rows], fontsize=8)
            ax.invert_yaxis()
            ax.set_xlabel(f"{head} ({unit})" if unit else head)
            ax.set_title(f"{task['name']}: {head}, 95 % intervals", fontsize=9)
            fig.tight_layout()
            name = f"{task['name']}-{metric}.png"
            fig.savefig(folder / name, dpi=90)
            plt.close(fig)
            out[(task["name"], metric)] = f"{folder.name}/{name}"
    return out


_SCRIPT = """
document.querySelectorAll('table.sortable th').forEach(function (th) {
  th.addEventListener('click', function () {
    var table = th.closest('table'), body = table.tBodies[0];
    var i = Array.prototype.indexOf.call(th.parentNode.children, th);
    var asc = th.dataset.asc !== '1';
    table.querySelectorAll('th').forEach(function (h) { delete h.dataset.asc; });
    th.dataset.asc = asc ? '1' : '0';
    var key = function (tr) {
      var t = tr.children[i].dataset.v || tr.children[i].textContent;
      var x = parseFloat(t);
      return isNaN(x) ? t : x;
    };
    Array.from(body.rows).sort(function (a, b) {
      var x = key(a), y = key(b);
      if (typeof x !== typeof y) { return typeof x === 'number' ? -1 : 1; }
      return (x < y ? -1 : x > y ? 1 : 0) * (asc ? 1 : -1);
    }).forEach(function (tr) { body.appendChild(tr); });
  });
});
"""

_STYLE = """
body { font-family: sans-serif; margin: 1.5em; max-width: 1200px; }
table { border-collapse: collapse; margin: 0.5em 0 1.5em; font-size: 0.85em; }
th, td { border: 1px solid #ccc; padding: 3px 6px; text-align: right; }
th { background: #eef; cursor: pointer; }
td.l, th.l { text-align: left; }
td a { color: inherit; text-decoration: none; }
td a:hover { text-decoration: underline; }
tr.first td { background: #efe; }
.note { color: #555; font-size: 0.85em; }
"""


def _value(row: Mapping[str, Any], metric: str) -> str:
    v = row.get(metric)
    return "" if v is None else f"{v}"


def write_leaderboard(doc: Mapping[str, Any], out: Path, figures: bool = True) -> Path:
    """Write ``out/leaderboard.html`` (and its figures under ``out/figures``)."""
    from odorloc.experiments.bench.results import overall_board

    links = draw_figures(doc, out / "figures") if figures else {}
    e = html.escape
    parts = [
        "<!doctype html><html><head><meta charset='utf-8'>",
        f"<title>odorloc bench {e(doc['suite'])} ({e(doc['tier'])})</title>",
        f"<style>{_STYLE}</style></head><body>",
        f"<h1>odorloc bench: suite {e(doc['suite'])}, tier {e(doc['tier'])}</h1>",
        f"<p class='note'>odorloc {e(str(doc.get('odorloc_version')))}; "
        f"{e(str(doc.get('machine')))}; wall time {doc.get('wall_time_s', 0):.0f} s on "
        f"{e(str(doc.get('backend')))} x {doc.get('workers')}; root seed {doc['seed']}. "
        "Intervals are 95 % (success: Wilson; means: bootstrap). Methods whose intervals "
        "overlap share a rank. Click a column head to sort; a value opens its figure.</p>",
        "<h2>Overall</h2>",
        "<table class='sortable'><thead><tr><th class='l'>method</th><th>mean normalised "
        "rank</th><th>tasks</th><th>ranked first</th></tr></thead><tbody>",
    ]
    for a in overall_board(doc["rows"]):
        parts.append(
            f"<tr><td class='l'>{e(a['method'])}</td><td>{a['mean_rank']:.2f}</td>"
            f"<td>{a['tasks']}</td><td>{a['firsts']}</td></tr>"
        )
    parts.append("</tbody></table>")
    for task in doc["tasks"]:
        rows = [r for r in doc["rows"] if r["task"] == task["name"]]
        cols = _columns(task)
        parts.append(f"<h2 id='{e(task['name'])}'>{e(task['name'])}</h2>")
        parts.append(
            f"<p class='note'>{e(task.get('summary', ''))}. Success: {e(task.get('rule', ''))}. "
            f"Scenario <code>{e(task['scenario'])}</code>, {task['episodes']} episodes per "
            f"method, ranked by {e(task['rank_by'].replace('_', ' '))}, "
            f"{task.get('wall_time_s', 0):.0f} s.</p>"
        )
        heads = "".join(
            f"<th>{e(COLUMNS[c][0])}{(' (' + e(COLUMNS[c][1]) + ')') if COLUMNS[c][1] else ''}</th>"
            for c in cols
        )
        ref = bool(task.get("reference"))
        parts.append(
            "<table class='sortable'><thead><tr><th>rank</th><th class='l'>method</th>"
            f"{heads}<th class='l'>failures</th>"
            + ("<th class='l'>published</th>" if ref else "")
            + "</tr></thead><tbody>"
        )
        for r in rows:
            cells = []
            for c in cols:
                text = e(_fmt(r, c))
                link = links.get((task["name"], c))
                if link:
                    text = f"<a href='{e(link)}'>{text}</a>"
                cells.append(f"<td data-v='{e(_value(r, c))}'>{text}</td>")
            cls = " class='first'" if r["rank"] == 1 else ""
            extra = ""
            if ref:
                chk = r.get("reference")
                extra = (
                    "<td class='l'>-</td>"
                    if not chk
                    else (
                        f"<td class='l'>{chk['mean']:.2f} &plusmn; {chk['sem']:.2f}: "
                        f"{'agrees' if chk['agrees'] else 'differs'}</td>"
                    )
                )
            parts.append(
                f"<tr{cls}><td>{r['rank']}</td><td class='l'>{e(r['method'])}</td>"
                + "".join(cells)
                + f"<td class='l'>{e(_failures(r))}</td>{extra}</tr>"
            )
        parts.append("</tbody></table>")
        skipped = task.get("skipped") or {}
        if skipped:
            parts.append(
                "<details class='note'><summary>"
                f"{len(skipped)} registered searchers do not run this task</summary><ul>"
                + "".join(f"<li>{e(m)}: {e(why)}</li>" for m, why in skipped.items())
                + "</ul></details>"
            )
    parts.append(f"<script>{_SCRIPT}</script></body></html>")
    path = out / "leaderboard.html"
    path.write_text("\n".join(parts), encoding="utf-8")
    return path


def text_board(doc: Mapping[str, Any], width: int = 80) -> str:
    """The board as plain text: one compact table per task (rank, method, success with its
    interval, search time, failures), then the overall ranking."""
    from odorloc.experiments.bench.results import overall_board

    lines = [f"suite {doc['suite']}, tier {doc['tier']}: {len(doc['rows'])} rows"]
    for task in doc["tasks"]:
        rows = [r for r in doc["rows"] if r["task"] == task["name"]]
        lines.append("")
        lines.append(
            f"{task['name']} ({task['episodes']} episodes, by {task['rank_by'].replace('_', ' ')})"
        )
        lines.append(f"{'rk':>3} {'method':<22} {'success %':<15} {'time s':>8} failures")
        for r in rows:
            fail = _failures(r)
            line = (
                f"{r['rank']:>3} {r['method'][:22]:<22} {_fmt(r, 'success'):<15} "
                f"{_fmt(r, 'search_time', False):>8} {fail}"
            )
            lines.append(line[:width])
    lines.append("")
    lines.append("overall (mean normalised rank, 0 = best; tasks; ranked first)")
    for a in overall_board(doc["rows"]):
        lines.append(
            f"  {a['method'][:30]:<30} {a['mean_rank']:.2f}  {a['tasks']:>2}  {a['firsts']:>2}"
        )
    return "\n".join(lines)


def markdown_board(doc: Mapping[str, Any]) -> str:
    """The board as Markdown tables (the documentation's page)."""
    from odorloc.experiments.bench.results import overall_board

    out = []
    for task in doc["tasks"]:
        rows = [r for r in doc["rows"] if r["task"] == task["name"]]
        cols = _columns(task)
        out.append(f"### {task['name']}\n")
        out.append(
            f"{task.get('summary', '')}. Success: {task.get('rule', '')}. "
            f"{task['episodes']} episodes per method, ranked by "
            f"{task['rank_by'].replace('_', ' ')}.\n"
        )
        heads = [COLUMNS[c][0] + (f" ({COLUMNS[c][1]})" if COLUMNS[c][1] else "") for c in cols]
        ref = bool(task.get("reference"))
        published = " published mean (s) |" if ref else ""
        out.append("| rank | method | " + " | ".join(heads) + " | failures |" + published)
        out.append("|---|---|" + "---|" * len(cols) + "---|" + ("---|" if ref else ""))
        for r in rows:
            cells = " | ".join(_fmt(r, c) for c in cols)
            chk = r.get("reference")
            note = ""
            if ref:
                note = (
                    " - |"
                    if not chk
                    else (
                        f" {chk['mean']:.2f} ± {chk['sem']:.2f}: "
                        f"{'agrees' if chk['agrees'] else 'differs'} |"
                    )
                )
            out.append(f"| {r['rank']} | {r['method']} | {cells} | {_failures(r)} |{note}")
        out.append("")
    out.append("### Overall\n")
    out.append("| method | mean normalised rank | tasks | ranked first |")
    out.append("|---|---|---|---|")
    for a in overall_board(doc["rows"]):
        out.append(f"| {a['method']} | {a['mean_rank']:.2f} | {a['tasks']} | {a['firsts']} |")
    return "\n".join(out) + "\n"
