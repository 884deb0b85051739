"""Animation of a stored episode for the HTML report's episode viewer."""

from __future__ import annotations

import tempfile
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from odorloc.engine.recorder import Recording
from odorloc.viz.episode import animate


def episode_gif(
    arrays: Mapping[str, np.ndarray], info: Mapping[str, Any] | None = None, max_frames: int = 60
) -> bytes:
    """GIF bytes animating an episode stored as :meth:`Recording.to_arrays` arrays."""
    rec = Recording.from_arrays(dict(arrays))
    if info:
        rec.meta.update({k: v for k, v in info.items() if isinstance(v, str | int | float | bool)})
    with tempfile.TemporaryDirectory() as d:
        path = animate(rec, Path(d) / "episode.gif", max_frames=max_frames)
        return path.read_bytes()
