"""Figures of a source-term posterior: its marginals over an episode, calibration histograms.

:func:`plot_posterior_marginals` draws one panel per component (position, release rate, wind
speed and direction, dispersion) with time across: each column is the weighted histogram of
the recorded particle snapshot at that time (normalised per column), with the posterior mean
and the truth where known. :func:`plot_pit_histograms` draws the probability-integral-transform
values of the truth under each episode's posterior: flat when the posterior is calibrated.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["plot_pit_histograms", "plot_posterior_marginals"]

#: Component label, unit and transform (column values -> plotted values) per column name.
_COMPONENTS: dict[str, tuple[str, str, Any]] = {
    "x": ("x", "m", None),
    "y": ("y", "m", None),
    "z": ("z", "m", None),
    "log_rate": ("release rate", "", np.exp),
    "speed": ("wind speed", "m/s", None),
    "direction": ("wind direction", "deg", np.degrees),
    "log_dispersion": ("dispersion factor", "", np.exp),
    "background": ("background", "", None),
}


def plot_posterior_marginals(
    snapshots: Sequence[tuple[float, Mapping[str, np.ndarray]]],
    path: str | Path,
    truth: Mapping[str, float] | None = None,
    title: str = "",
    bins: int = 40,
) -> Path:
    """Marginals of a single-source posterior over time (module docstring).

    Parameters
    ----------
    snapshots : sequence of (t, snapshot)
        Recorded source-term belief snapshots (``theta``, ``theta_columns``, ``weights``).
    path : path
        PNG written.
    truth : dict, optional
        True values by column name (``x``, ``y``, ``log_rate`` as a *rate*, ``speed``,
        ``direction`` in degrees, ...), drawn as dashed lines.
    title : str
    bins : int
        Histogram bins per panel.
    """
    import matplotlib.pyplot as plt

    snaps = [(float(t), s) for t, s in snapshots if "theta" in s]
    if not snaps:
        raise ValueError("no source-term snapshots to draw")
    cols = [str(c) for c in np.asarray(snaps[0][1]["theta_columns"]).tolist()]
    shown = [c for c in cols if c in _COMPONENTS]
    times = np.array([t for t, _ in snaps])
    n = len(shown)
    ncol = 2 if n > 3 else 1
    nrow = math.ceil(n / ncol)
    fig, axes = plt.subplots(nrow, ncol, figsize=(6.2 * ncol, 2.3 * nrow + 0.6), squeeze=False)
    edges_t = np.concatenate([times, [times[-1] + (times[-1] - times[0]) / max(len(times), 1)]])
    if len(times) > 1:
        mid = 0.5 * (times[1:] + times[:-1])
        edges_t = np.concatenate(
            [[times[0] - (mid[0] - times[0])], mid, [times[-1] + (times[-1] - mid[-1])]]
        )
    for k, name in enumerate(shown):
        ax = axes[k // ncol, k % ncol]
        label, unit, f = _COMPONENTS[name]
        c = cols.index(name)
        raw = [np.asarray(s["theta"])[:, c] for _, s in snaps]
        if name == "direction":
            # unwrap around the circular mean of all snapshots, so no panel splits at +-180 deg
            ref = math.atan2(
                np.mean([np.sin(v).mean() for v in raw]), np.mean([np.cos(v).mean() for v in raw])
            )
            raw = [ref + np.angle(np.exp(1j * (v - ref))) for v in raw]
        vals = [
            (f(v) if f else v, np.asarray(s["weights"], float))
            for v, (_, s) in zip(raw, snaps, strict=True)
        ]
        allv = np.concatenate([v for v, _ in vals])
        tv = None if truth is None else truth.get(name)
        log_scale = name in ("log_rate", "log_dispersion")
        lo, hi = np.percentile(allv, [0.5, 99.5])
        if tv is not None and math.isfinite(tv):
            lo, hi = min(lo, tv), max(hi, tv)
        if log_scale:
            lo, hi = max(lo, 1e-12), max(hi, lo * 1.01)
            edges = np.geomspace(lo / 1.05, hi * 1.05, bins + 1)
        else:
            pad = 0.05 * (hi - lo) + 1e-9
            edges = np.linspace(lo - pad, hi + pad, bins + 1)
        img = np.zeros((bins, len(snaps)))
        means = np.zeros(len(snaps))
        for j, (v, w) in enumerate(vals):
            h, _ = np.histogram(v, bins=edges, weights=w)
            img[:, j] = h / max(h.max(), 1e-300)
            means[j] = float(np.exp(w @ np.log(v)) if log_scale else w @ v)
        ax.pcolormesh(edges_t, edges, img, cmap="Blues", shading="flat", vmin=0, vmax=1)
        ax.plot(times, means, color="tab:orange", lw=1.2, label="posterior mean")
        if tv is not None and math.isfinite(tv):
            ax.axhline(tv, color="tab:red", ls="--", lw=1.2, label="truth")
        if log_scale:
            ax.set_yscale("log")
        ax.set_ylabel(f"{label} ({unit})" if unit else label)
        ax.set_xlabel("time (s)")
        if k == 0:
            ax.legend(loc="upper right", fontsize=7)
    for k in range(n, nrow * ncol):
        axes[k // ncol, k % ncol].axis("off")
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    out = Path(path)
    fig.savefig(out, dpi=100)
    plt.close(fig)
    return out


def plot_pit_histograms(
    pits: Mapping[str, np.ndarray], path: str | Path, title: str = "", bins: int = 10
) -> Path:
    """Histograms of probability-integral-transform values, one panel per component.

    Parameters
    ----------
    pits : dict of str to (n,) ndarray
        Per component, the posterior probability below the truth in each episode (in
        ``[0, 1]``; NaN left out).
    path : path
    title : str
    bins : int
    """
    import matplotlib.pyplot as plt

    names = list(pits)
    fig, axes = plt.subplots(1, max(len(names), 1), figsize=(3.2 * max(len(names), 1), 2.8))
    axes = np.atleast_1d(axes)
    for ax, name in zip(axes, names, strict=False):
        v = np.asarray(pits[name], float)
        v = v[np.isfinite(v)]
        ax.hist(v, bins=np.linspace(0, 1, bins + 1), color="tab:blue", alpha=0.8, edgecolor="w")
        if len(v):
            ax.axhline(len(v) / bins, color="tab:red", ls="--", lw=1, label="calibrated")
            ax.legend(fontsize=7)
        ax.set_xlabel(f"P(posterior < truth), {name}")
        ax.set_ylabel("episodes")
        ax.set_xlim(0, 1)
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    out = Path(path)
    fig.savefig(out, dpi=100)
    plt.close(fig)
    return out
