"""Release rates drawn per episode by the uniform source draw."""

from __future__ import annotations

import numpy as np
import pytest

from odorloc.geometry.arena import Arena
from odorloc.plume.source_draw import UniformSourceDraw, UniformSourceDrawParams
from odorloc.plume.sources import Source


def test_rates_are_drawn_after_the_positions_and_within_their_range() -> None:
    arena = Arena.box([0, 0], [20, 20], 0.5)
    sources = [Source(position=(1.0, 1.0), rate=7.0), Source(position=(2.0, 2.0), rate=7.0)]
    starts = np.array([[19.0, 19.0]])
    plain = UniformSourceDraw(UniformSourceDrawParams(min_separation=2.0))
    drawn = UniformSourceDraw(UniformSourceDrawParams(min_separation=2.0, rates=(0.5, 8.0)))
    a = plain.draw(sources, arena, starts, np.random.default_rng(3))
    b = drawn.draw(sources, arena, starts, np.random.default_rng(3))
    # the same positions: the rates come after them from the same stream
    assert [s.position for s in a] == [s.position for s in b]
    assert [s.rate for s in a] == [7.0, 7.0]
    assert all(0.5 <= s.rate <= 8.0 for s in b) and b[0].rate != b[1].rate
    # log-uniform: the log rates are uniform (a median near the geometric mean)
    rng = np.random.default_rng(4)
    r = drawn.rates(20000, rng)
    assert r is not None
    assert np.median(r) == pytest.approx(2.0, rel=0.05)
    u = UniformSourceDraw(UniformSourceDrawParams(rates=(0.5, 8.0), rate_law="uniform"))
    ru = u.rates(20000, rng)
    assert ru is not None and np.median(ru) == pytest.approx(4.25, rel=0.05)


def test_an_inverted_rate_range_is_refused() -> None:
    with pytest.raises(ValueError, match="rates"):
        UniformSourceDrawParams(rates=(5.0, 1.0))
