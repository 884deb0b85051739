"""Build every continuous plume family, step it, and save a PNG of its concentration field.

Run: ``python examples/plumes.py OUTDIR`` (writes ``OUTDIR/plume_<family>.png``).
"""

from __future__ import annotations

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.colors import LogNorm

from odorloc.geometry.arena import Arena
from odorloc.models.gaussian import GaussianParams
from odorloc.plume import (
    EulerianParams,
    EulerianPlume,
    FilamentParams,
    FilamentPlume,
    GaussianPlume,
    ReplayPlume,
    VergassolaParams,
    VergassolaPlume,
    record_movie,
)
from odorloc.plume.sources import Source
from odorloc.wind.uniform import UniformWind, UniformWindParams


def field(plume, nx: int = 300, ny: int = 150) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Concentration on a regular grid covering the arena: x, y (metres) and ``(ny, nx)``."""
    lo, hi = plume.arena.lo, plume.arena.hi
    x = np.linspace(lo[0], hi[0], nx)
    y = np.linspace(lo[1], hi[1], ny)
    xx, yy = np.meshgrid(x, y)
    return x, y, plume.concentration(np.column_stack([xx.ravel(), yy.ravel()])).reshape(ny, nx)


def save(plume, title: str, path: Path, log: bool = True) -> None:
    x, y, c = field(plume)
    fig, ax = plt.subplots(figsize=(8, 4))
    if log:
        top = max(float(c.max()), 1e-12)
        norm = LogNorm(vmin=top * 1e-3, vmax=top)
        img = ax.pcolormesh(x, y, np.where(c > 0, c, np.nan), norm=norm, shading="auto")
    else:
        img = ax.pcolormesh(x, y, c, shading="auto")
    occ = plume.arena.occ
    if occ is not None:
        cx, cy = plume.arena.cell_centers()
        ax.contourf(cx, cy, occ.T.astype(float), levels=[0.5, 1.5], colors="0.3")
    src = plume.source_positions
    ax.plot(src[:, 0], src[:, 1], "r*", ms=12, mec="w", label="source")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_aspect("equal")
    ax.set_xlim(x[0], x[-1])
    ax.set_ylim(y[0], y[-1])
    ax.set_title(f"{title}, t = {plume.t:.1f} s")
    ax.legend(loc="upper right", fontsize=8)
    fig.colorbar(img, ax=ax, label="concentration")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(outdir: Path) -> None:
    outdir.mkdir(parents=True, exist_ok=True)
    arena = Arena.box((0, 0), (20, 10), resolution=0.1).with_boxes([((12, 2.0), (12.5, 5.0))])
    wind = UniformWind(UniformWindParams(velocity=(1.0, 0.15)), arena)
    sources = [Source(position=(2.0, 5.0), rate=40.0)]
    rng = np.random.default_rng(0)

    filament = FilamentPlume(
        FilamentParams(sigma0=0.1, gamma=0.01, noise_std=0.25), arena, wind, sources
    )
    gaussian = GaussianPlume(GaussianParams(sigma0=0.1, K=0.05), arena, wind, sources)
    vergassola = VergassolaPlume(
        VergassolaParams(V=None, D=0.2, tau=20.0, sensor_radius=0.1),
        arena,
        wind,
        [Source(position=(2.0, 5.0), rate=5.0)],
    )
    eulerian = EulerianPlume(EulerianParams(D=0.02), arena, wind, sources)
    plumes = {
        "filament": ("Filament plume", filament, True),
        "gaussian": ("Gaussian plume", gaussian, True),
        "vergassola": ("Vergassola rate model (concentration)", vergassola, True),
        "eulerian": ("Eulerian advection-diffusion", eulerian, True),
    }
    for name, (title, plume, log) in plumes.items():
        plume.reset(rng)
        for _ in range(250):
            plume.step(0.1, rng)
        save(plume, title, outdir / f"plume_{name}.png", log)

    # Replay: record 30 s of a fresh filament plume, play it back to t = 25 s.
    fresh = FilamentPlume(
        FilamentParams(sigma0=0.1, gamma=0.01, noise_std=0.25), arena, wind, sources
    )
    movie = record_movie((fresh, wind), 30.0, 0.5, np.random.default_rng(1), dt=0.1)
    replay = ReplayPlume.from_movie(movie)
    replay.step(25.0, rng)
    save(replay, "Replayed filament movie", outdir / "plume_replay.png", True)
    print(f"wrote {len(plumes) + 1} PNGs to {outdir}")


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit("usage: python examples/plumes.py OUTDIR")
    main(Path(sys.argv[1]))
