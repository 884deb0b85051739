"""A fast RGB raster of a live scene (plume slice, obstacles, sources, agents and their trails),
for environments' ``render()`` and quick looks; no figure is created.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence

import numpy as np
from matplotlib import colormaps

__all__ = ["render_rgb"]

_AGENT_RGB = np.array(
    [
        [214, 39, 40],
        [31, 119, 180],
        [44, 160, 44],
        [255, 127, 14],
        [148, 103, 189],
        [140, 86, 75],
    ],
    np.uint8,
)


def _disc(img: np.ndarray, cx: float, cy: float, r: float, rgb: Sequence[int]) -> None:
    h, w, _ = img.shape
    x0, x1 = max(int(cx - r), 0), min(int(cx + r) + 1, w)
    y0, y1 = max(int(cy - r), 0), min(int(cy + r) + 1, h)
    if x0 >= x1 or y0 >= y1:
        return
    yy, xx = np.mgrid[y0:y1, x0:x1]
    m = (xx - cx) ** 2 + (yy - cy) ** 2 <= r * r
    img[y0:y1, x0:x1][m] = rgb


def render_rgb(
    field: np.ndarray,
    extent: Sequence[float],
    *,
    occupancy: np.ndarray | None = None,
    sources: np.ndarray | None = None,
    trails: Sequence[np.ndarray] = (),
    declared: np.ndarray | None = None,
    width: int = 480,
) -> np.ndarray:
    """An RGB image of a horizontal scene.

    Parameters
    ----------
    field : (nx, ny) ndarray
        Concentration on a regular grid over ``extent`` (index ``[i, j]`` is x then y); drawn
        on a logarithmic viridis scale, zero as white.
    extent : (xmin, xmax, ymin, ymax), metres
    occupancy : (mx, my) bool ndarray, optional
        Obstacle cells over the same extent (drawn grey).
    sources : (S, >=2) ndarray, optional, metres
        True sources (gold squares).
    trails : sequence of (K, >=2) ndarray, metres
        Each agent's path so far; the last point is the agent (a disc in its colour).
    declared : (K, >=2) ndarray, optional, metres
        Declared positions (magenta).
    width : int
        Image width in pixels; the height follows the aspect ratio.

    Returns
    -------
    (H, W, 3) uint8 ndarray
    """
    x0, x1, y0, y1 = (float(v) for v in extent)
    height = max(8, round(width * (y1 - y0) / max(x1 - x0, 1e-12)))
    px = np.linspace(x0, x1, width, endpoint=False) + 0.5 * (x1 - x0) / width
    py = np.linspace(y1, y0, height, endpoint=False) - 0.5 * (y1 - y0) / height

    def cells(shape: tuple[int, ...]) -> tuple[np.ndarray, np.ndarray]:
        ix = np.clip(((px - x0) / (x1 - x0) * shape[0]).astype(int), 0, shape[0] - 1)
        iy = np.clip(((py - y0) / (y1 - y0) * shape[1]).astype(int), 0, shape[1] - 1)
        return ix, iy

    f = np.asarray(field, float)
    img = np.full((height, width, 3), 255, np.uint8)
    ix, iy = cells(f.shape)
    vals = f[ix[None, :], iy[:, None]]
    pos = f[f > 0]
    if pos.size:
        hi = float(np.percentile(pos, 99.5))
        lo = max(hi * 1e-3, float(pos.min()))
        hi = max(hi, lo * 10)
        z = np.clip((np.log(np.maximum(vals, lo)) - np.log(lo)) / (np.log(hi) - np.log(lo)), 0, 1)
        rgb = (colormaps["viridis"](z)[..., :3] * 255).astype(np.uint8)
        on = vals > lo
        img[on] = rgb[on]
    if occupancy is not None:
        occ = np.asarray(occupancy, bool)
        ox, oy = cells(occ.shape)
        img[occ[ox[None, :], oy[:, None]]] = (90, 90, 90)

    def to_px(p: np.ndarray) -> tuple[float, float]:
        return (p[0] - x0) / (x1 - x0) * width, (y1 - p[1]) / (y1 - y0) * height

    r = max(2.0, width / 120.0)
    for k, trail in enumerate(trails):
        tr = np.asarray(trail, float)
        if len(tr) == 0:
            continue
        col = _AGENT_RGB[k % len(_AGENT_RGB)]
        for a, b in itertools.pairwise(tr):
            (ax, ay), (bx, by) = to_px(a), to_px(b)
            n = max(2, int(np.hypot(bx - ax, by - ay)) + 1)
            xs = np.linspace(ax, bx, n).astype(int)
            ys = np.linspace(ay, by, n).astype(int)
            ok = (xs >= 0) & (xs < width) & (ys >= 0) & (ys < height)
            img[ys[ok], xs[ok]] = col
        _disc(img, *to_px(tr[-1]), r * 1.6, (0, 0, 0))
        _disc(img, *to_px(tr[-1]), r * 1.2, col)
    if sources is not None:
        for s in np.asarray(sources, float):
            cx, cy = (int(v) for v in to_px(s))
            for q, col in ((int(r * 2.0), (0, 0, 0)), (int(r * 1.4), (255, 215, 0))):
                img[max(cy - q, 0) : cy + q + 1, max(cx - q, 0) : cx + q + 1] = col
    if declared is not None:
        for s in np.atleast_2d(np.asarray(declared, float)):
            _disc(img, *to_px(s), r * 1.3, (230, 0, 230))
    return img
