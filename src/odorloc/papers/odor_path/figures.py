"""Figures of the odor-path paper: path maps and sub-window ellipses for calm and gusty wind."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

__all__ = ["odor_path_figure", "synthetic_wind_record"]


def synthetic_wind_record(
    n: int,
    dt: float,
    speed: float,
    direction_std_deg: float,
    rng: np.random.Generator,
    correlation_time: float = 5.0,
) -> np.ndarray:
    """A wind record ``(n, 2)`` m/s whose direction follows an Ornstein-Uhlenbeck process.

    Mean ``speed`` along +x; the direction's stationary standard deviation is
    ``direction_std_deg`` and its correlation time ``correlation_time`` seconds; the speed
    fluctuates with a 10 % standard deviation and the same correlation time (starting at
    ``speed``).
    """
    a = math.exp(-dt / correlation_time)
    s = math.radians(direction_std_deg)
    th = np.empty(n)
    z = np.empty(n)  # unit-variance process behind the speed: speed (1 + 0.1 z)
    th[0] = rng.normal(0.0, s)
    z[0] = 0.0
    for i in range(1, n):
        th[i] = a * th[i - 1] + math.sqrt(1 - a * a) * rng.normal(0.0, s)
        z[i] = a * z[i - 1] + math.sqrt(1 - a * a) * rng.normal()
    sp = speed * (1.0 + 0.1 * z)
    return np.column_stack([sp * np.cos(th), sp * np.sin(th)])


def odor_path_figure(path: Path, seed: int = 7) -> Path:
    """Odor-path maps with their sub-window ellipses for a calm and a gusty wind record.

    Like Figs. 4-5 of the odor-path paper: a 10 m x 10 m map of 5 cm cells, the robot at
    (8, 5) m, 10 s of wind (20 records at 0.5 s) with direction standard deviation 5 deg
    (calm) and 35 deg (gusty).
    """
    from odorloc.viz.backend import pyplot

    plt = pyplot()
    from matplotlib.colors import PowerNorm
    from matplotlib.patches import Ellipse

    from odorloc.inference.odor_path import OdorPathEstimator, OdorPathParams

    rng = np.random.default_rng(seed)
    fig, axes = plt.subplots(1, 2, figsize=(11, 5))
    for ax, (name, std) in zip(axes, (("calm", 5.0), ("gusty", 35.0)), strict=True):
        est = OdorPathEstimator(OdorPathParams(cell_size=0.05), (0.0, 0.0), (10.0, 10.0))
        wind = synthetic_wind_record(21, 0.5, 0.5, std, rng)
        for i, u in enumerate(wind):
            est.update(0.5 * i, (8.0, 5.0), u, 1.0)
        pi = est.path_map()
        var = est.wind_variance()
        # a power norm: the newest windows hold pi ~ 1, the oldest a few per cent
        im = ax.imshow(
            pi.T,
            origin="lower",
            extent=(0, 10, 0, 10),
            cmap="viridis",
            norm=PowerNorm(0.35, vmin=0.0, vmax=max(float(pi.max()), 1e-12)),
        )
        for w in est.windows():
            if w.n_cells:
                ax.add_patch(
                    Ellipse(
                        tuple(w.center),
                        2 * w.semi_axes[0],
                        2 * w.semi_axes[1],
                        fill=False,
                        ec="w",
                        lw=0.6,
                    )
                )
        ax.plot(8.0, 5.0, "o", color="red", mec="k")
        ax.set_title(
            f"{name}: direction sd {std:.0f} deg, wind var ({var[0]:.1e}, {var[1]:.1e}) m²/s²",
            fontsize=9,
        )
        fig.colorbar(im, ax=ax, shrink=0.8, label="π (odor-path probability)")
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
    fig.suptitle(
        "Odor-path probability maps and sub-window ellipses (cf. odor-path paper Figs. 4-5)"
    )
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path
