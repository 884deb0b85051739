"""Team figures: one colour per agent shared by every figure, small-multiple traces, markers
that never hide the true source, wide animations with the belief drawn, progress while writing.

Drawn from hand-made recordings (no simulation), so these run in seconds."""

from __future__ import annotations

from typing import Any

import matplotlib.pyplot as plt
import numpy as np
import pytest
from matplotlib import colors
from matplotlib.image import AxesImage
from PIL import Image

from odorloc.engine.recorder import Recording
from odorloc.viz import episode as viz
from odorloc.viz.team import MAX_AGENT_PANELS, PALETTE, team_style
from odorloc.viz.team3d import animate_team_3d


def _team(
    n: int,
    *,
    groups: list[dict[str, Any]] | None = None,
    platform: str = "holonomic",
    dim: int = 2,
    steps: int = 12,
    diagnostics: dict[str, np.ndarray] | None = None,
    beliefs: list[tuple[float, dict[str, np.ndarray]]] | None = None,
    declared: np.ndarray | None = None,
    sources: np.ndarray | None = None,
) -> Recording:
    t = np.arange(steps, dtype=float)
    hi = np.array([20.0, 10.0, 5.0][:dim])
    starts = np.array([[18.0, 0.5 + 9.0 * a / max(n - 1, 1), 2.0][:dim] for a in range(n)])
    positions = starts[None] + t[:, None, None] * np.array([-0.5, 0.0, 0.0][:dim])
    det = np.zeros((steps, n), bool)
    det[steps // 2 :, 0] = True
    wind = np.zeros((steps, n, dim))
    wind[..., 0] = -1.0
    frame = np.full((20, 10), 0.5, np.float32)
    src = np.array([[2.0, 5.0, 1.0][:dim], [4.0, 3.0, 1.0][:dim]]) if sources is None else sources
    return Recording(
        t=t,
        positions=positions,
        gas=np.random.default_rng(0).uniform(0, 1, (steps, n)),
        detection=det,
        wind=wind,
        diagnostics=diagnostics or {},
        beliefs=beliefs or [],
        plume_t=np.array([0.0]),
        plume_frames=frame[None],
        plume_extent=np.array([0.0, 20.0, 0.0, 10.0]),
        sources=src,
        declared=np.zeros((0, dim)) if declared is None else declared,
        occupancy=None,
        arena_bounds=np.array([np.zeros(dim), hi]),
        meta={"scenario": "team-test", "platform": platform, "groups": groups or []},
    )


TWO_GROUPS = [{"name": "A", "agents": list(range(6))}, {"name": "B", "agents": list(range(6, 12))}]


def _hex(c: Any) -> str:
    return colors.to_hex(c, keep_alpha=False)


# ----------------------------------------------------------------------------- colours


def test_a_small_team_gets_distinct_palette_colours() -> None:
    style = team_style(len(PALETTE))
    hexes = [_hex(style.color(a)) for a in range(len(PALETTE))]
    assert len(set(hexes)) == len(PALETTE)
    # none is the true source's gold, the declaration's magenta or a particle grey
    for reserved in ("gold", "magenta", "0.5"):
        assert _hex(reserved) not in hexes
    for c in hexes:
        r, g, b = colors.to_rgb(c)
        assert not (r == g == b)


def test_groups_get_one_hue_family_each_and_distinct_members() -> None:
    style = team_style(12, {"groups": TWO_GROUPS, "platform": "holonomic"})
    rgb = np.array([style.color(a)[:3] for a in range(12)])
    # group A in reds (red dominates), group B in blues (blue dominates)
    assert np.all(rgb[:6, 0] > rgb[:6, 2]) and np.all(rgb[6:, 2] > rgb[6:, 0])
    assert len({_hex(c) for c in rgb}) == 12
    units = style.units()
    assert [u.label for u in units] == ["group A (robots 0-5)", "group B (robots 6-11)"]
    assert units[0].agents == tuple(range(6))


def test_units_are_agents_up_to_six_then_groups_then_the_team() -> None:
    assert len(team_style(MAX_AGENT_PANELS).units()) == MAX_AGENT_PANELS
    one = team_style(MAX_AGENT_PANELS + 1).units()
    assert len(one) == 1 and one[0].agents == tuple(range(MAX_AGENT_PANELS + 1))
    assert team_style(3, {"platform": "uav"}).name(2) == "UAV 2"
    assert team_style(1, {"platform": "uav"}).name(0) == "UAV"


def test_every_figure_gives_an_agent_the_same_colour(tmp_path, monkeypatch) -> None:
    rec = _team(3, platform="uav")
    want = [_hex(team_style(3, rec.meta).color(a)) for a in range(3)]
    fig = viz.plot_trajectory(rec)
    paths = [ln for ln in fig.axes[0].get_lines() if ln.get_linestyle() == "-"]
    assert [_hex(ln.get_color()) for ln in paths] == want
    plt.close(fig)
    fig = viz.plot_traces(rec)
    titled = [ax for ax in fig.axes if ax.get_title()]
    assert [ax.get_title() for ax in titled] == ["UAV 0", "UAV 1", "UAV 2"]
    assert [_hex(ax.title.get_color()) for ax in titled] == want
    plt.close(fig)
    kept: list[Any] = []
    monkeypatch.setattr(plt, "close", kept.append)
    viz.animate(rec, tmp_path / "a.gif", max_frames=2, dpi=40)
    heads = [ln for ln in kept[0].axes[0].get_lines() if ln.get_marker() == "o"]
    assert [_hex(ln.get_color()) for ln in heads[:3]] == want


# ----------------------------------------------------------------------------- traces


def test_traces_of_twelve_robots_are_two_group_columns_with_bands() -> None:
    rec = _team(12, groups=TWO_GROUPS)
    fig = viz.plot_traces(rec)
    titles = [ax.get_title() for ax in fig.axes if ax.get_title()]
    assert titles == ["group A (robots 0-5)", "group B (robots 6-11)"]
    gas = [ax for ax in fig.axes if ax.get_title().startswith("group")]
    for ax in gas:
        # a band (min-max over the members) and the detection strip: filled areas, not ticks
        assert len(ax.collections) >= 2
        assert not [ln for ln in ax.get_lines() if ln.get_marker() == "|"]
    assert "share of the group detecting" in fig.get_suptitle()
    plt.close(fig)


def test_team_diagnostics_are_drawn_in_their_agents_columns() -> None:
    steps = 12
    diag = {
        "spread": np.full(steps, 1.0),
        "spread_1": np.full(steps, 2.0),
        "spread_2": np.full(steps, 3.0),
        "entropy": np.linspace(4.0, 3.0, steps),
        # a phase is text: it has no trace
        "phase": np.array(["zigzag"] * 6 + ["surge"] * (steps - 6)),
        "phase_1": np.array(["zigzag"] * steps),
    }
    rec = _team(3, platform="uav", diagnostics=diag, steps=steps)
    assert set(viz.diagnostics_by_agent(rec)) == {"spread", "entropy"}
    assert set(viz.diagnostics_by_agent(rec)["spread"]) == {0, 1, 2}
    # the unsuffixed series of a team without suffixed ones is a central belief's
    assert set(viz.diagnostics_by_agent(rec)["entropy"]) == {-1}
    fig = viz.plot_traces(rec)
    spread_row = [ax for ax in fig.axes if ax.get_ylabel() == viz.TRACE_DIAGNOSTICS["spread"]]
    assert len(spread_row) == 1  # the label on the first column only
    row = fig.axes[fig.axes.index(spread_row[0]) : fig.axes.index(spread_row[0]) + 3]
    assert [float(ax.get_lines()[0].get_ydata()[0]) for ax in row] == [1.0, 2.0, 3.0]
    central = [ax for ax in fig.axes if "central belief" in ax.get_title(loc="left")]
    assert len(central) == 1
    plt.close(fig)


# ----------------------------------------------------------------------------- markers


@pytest.mark.parametrize("figure", ["trajectory", "belief", "animation"])
def test_the_true_source_is_drawn_above_every_other_marker(tmp_path, monkeypatch, figure) -> None:
    # a declaration exactly on the second source
    decl = np.array([[4.0, 3.0]])
    snap = {"prob": np.full((20, 10), 1 / 200), "lower": np.zeros(2), "upper": [20.0, 10.0]}
    rec = _team(2, declared=decl, beliefs=[(0.0, {**snap, "agent": np.array(-1)})])
    kept: list[Any] = []
    if figure == "trajectory":
        axes = viz.plot_trajectory(rec).axes[:1]
    elif figure == "belief":
        axes = viz.plot_belief_map(rec).axes[:1]
    else:
        monkeypatch.setattr(plt, "close", kept.append)
        viz.animate(rec, tmp_path / "a.gif", max_frames=2, dpi=40)
        axes = [ax for ax in kept[0].axes if ax.get_label() in ("map", "belief")]
    for ax in axes:
        stars = [ln for ln in ax.get_lines() if ln.get_marker() == "*"]
        assert stars and np.allclose(stars[0].get_xydata(), rec.sources[:, :2])
        others = [a for a in ax.get_children() if a not in stars and hasattr(a, "get_zorder")]
        assert stars[0].get_zorder() > max(a.get_zorder() for a in others)
        ring = [ln for ln in ax.get_lines() if ln.get_marker() == "o" and ln.get_mfc() == "none"]
        # the declaration is a ring wider than the star: both stay visible
        assert ring and ring[0].get_markersize() > stars[0].get_markersize()
    plt.close("all")


def test_a_log_without_known_sources_draws_no_true_source() -> None:
    rec = _team(1, sources=np.zeros((0, 2)))
    fig = viz.plot_belief_map(rec)
    labels = [t.get_text() for leg in fig.legends for t in leg.get_texts()]
    assert "true source" not in labels
    assert not [ln for ln in fig.axes[0].get_lines() if ln.get_marker() == "*"]
    plt.close(fig)


# ----------------------------------------------------------------------------- animations


def test_animation_draws_a_grid_belief_at_its_recorded_extent(tmp_path, monkeypatch) -> None:
    prob = np.zeros((8, 4))
    prob[1, 2] = 1.0
    snap = {"m_s": prob, "lower": np.array([2.0, 4.0]), "upper": np.array([10.0, 8.0])}
    rec = _team(1, beliefs=[(3.0, {**snap, "agent": np.array(-1)})])
    kept: list[Any] = []
    monkeypatch.setattr(plt, "close", kept.append)
    calls: list[tuple[int, int]] = []
    viz.animate(
        rec, tmp_path / "ds.gif", max_frames=6, dpi=40, progress=lambda i, n: calls.append((i, n))
    )
    belief = next(ax for ax in kept[0].axes if ax.get_label() == "belief")
    (img,) = [im for im in belief.get_images() if isinstance(im, AxesImage)]
    # the last frame shows the map (drawn from its snapshot's time on) where it was recorded
    assert tuple(img.get_extent()) == (2.0, 10.0, 4.0, 8.0)
    assert np.nanmax(np.asarray(img.get_array(), float)) == pytest.approx(1.0)
    # progress after every frame, ending at the total
    assert calls == [(i, 6) for i in range(1, 7)]


def test_team_3d_animation_is_wide_with_the_legend_beside_the_view(tmp_path) -> None:
    rec = _team(3, platform="uav", dim=3)
    calls: list[int] = []
    path = animate_team_3d(
        rec, tmp_path / "t.gif", max_frames=3, dpi=40, progress=lambda i, n: calls.append(i)
    )
    with Image.open(path) as im:
        assert im.size[0] >= viz.MIN_ANIMATION_WIDTH
    assert calls == [1, 2, 3]
