"""Episode figures and animations (``odorloc.viz.episode``, ``odorloc.viz.team3d``), drawn from
small hand-made recordings so that no simulation runs."""

from __future__ import annotations

from typing import Any

import matplotlib.pyplot as plt
import numpy as np
import pytest
from matplotlib import colors
from matplotlib.collections import PathCollection
from matplotlib.image import AxesImage
from PIL import Image

from odorloc.engine.recorder import Recording
from odorloc.viz import episode as viz
from odorloc.viz.team3d import key_moments, plot_team_3d


def _recording(
    n_agents: int = 1,
    *,
    dim: int = 2,
    beliefs: list[tuple[float, dict[str, np.ndarray]]] | None = None,
    declared: np.ndarray | None = None,
    events: list[dict[str, Any]] | None = None,
    detection: np.ndarray | None = None,
    steps: int = 20,
) -> Recording:
    """A 10 m x 6 m (x 4 m) episode: agents walk left at 0.4 m/s, wind towards -y."""
    t = np.arange(steps, dtype=float)
    lo = np.zeros(dim)
    hi = np.array([10.0, 6.0, 4.0][:dim])
    starts = np.array([[9.0, 1.0 + 1.5 * a, 2.0][:dim] for a in range(n_agents)])
    step = np.array([-0.4, 0.0, 0.0][:dim])
    positions = starts[None] + t[:, None, None] * step
    x, y = np.meshgrid(np.linspace(0, 10, 20), np.linspace(0, 6, 12), indexing="ij")
    frame = np.exp(-((x - 1.0) ** 2 + (y - 3.0) ** 2) / 4.0).astype(np.float32)
    wind = np.zeros((steps, n_agents, dim))
    wind[..., 1] = -1.0
    return Recording(
        t=t,
        positions=positions,
        gas=np.zeros((steps, n_agents)),
        detection=np.zeros((steps, n_agents), bool) if detection is None else detection,
        wind=wind,
        diagnostics={},
        beliefs=beliefs or [],
        plume_t=np.array([0.0, 10.0]),
        plume_frames=np.stack([frame, frame]),
        plume_extent=np.array([0.0, 10.0, 0.0, 6.0]),
        sources=np.array([[1.0, 3.0, 1.0][:dim]]),
        declared=np.zeros((0, dim)) if declared is None else declared,
        occupancy=None,
        arena_bounds=np.array([lo, hi]),
        meta={"scenario": "viz-test", "searcher": "test", "events": events or []},
    )


def _particles(agent: int, centre: tuple[float, float], n: int = 50, equal: bool = False) -> dict:
    rng = np.random.default_rng(agent + 5)
    pos = np.asarray(centre) + rng.normal(0.0, 0.5, (n, 2))
    w = np.full(n, 1.0 / n) if equal else rng.uniform(0.1, 1.0, n)
    return {"positions": pos, "weights": w / w.sum(), "agent": np.array(agent)}


@pytest.fixture
def kept_figures(monkeypatch: pytest.MonkeyPatch) -> list[Any]:
    """Figures the viz functions would close, kept open to inspect (in their final state)."""
    kept: list[Any] = []
    close = plt.close
    monkeypatch.setattr(plt, "close", kept.append)
    yield kept
    for fig in kept:
        close(fig)


def _magenta_frames(path: Any) -> list[bool]:
    """Per GIF frame: does its map (left of the legend's column) show a declared-source ring?"""
    counts = []
    with Image.open(path) as im:
        for i in range(im.n_frames):
            im.seek(i)
            rgb = np.asarray(im.convert("RGB"), int)
            rgb = rgb[:, : int(0.6 * rgb.shape[1])]
            counts.append(int((np.abs(rgb - np.array([255, 0, 255])).sum(axis=2) < 60).sum()))
    return [c > 3 for c in counts]


def test_animation_shows_the_declaration_from_its_time_on(tmp_path) -> None:
    decl = np.array([[5.0, 4.5]])
    events = [{"t": 6.0, "kind": "declaration", "agent": 0, "position": decl.tolist()}]
    rec = _recording(declared=decl, events=events, steps=10)
    path = viz.animate(rec, tmp_path / "a.gif", max_frames=10, dpi=40)
    assert _magenta_frames(path) == [k >= 6 for k in range(10)]
    # Without declaration events (a replayed log) it appears on the last frame.
    rec.meta["events"] = []
    path = viz.animate(rec, tmp_path / "b.gif", max_frames=10, dpi=40)
    assert _magenta_frames(path) == [k == 9 for k in range(10)]


def _named(fig: Any, label: str) -> Any:
    return next(ax for ax in fig.axes if ax.get_label() == label)


def test_animation_legend_sits_outside_the_maps_with_visible_proxies(tmp_path, kept_figures):
    beliefs = [(0.0, _particles(0, (5.0, 3.0)))]
    decl = np.array([[1.2, 3.1]])
    path = viz.animate(
        _recording(beliefs=beliefs, declared=decl), tmp_path / "a.gif", max_frames=4, dpi=40
    )
    (fig,) = kept_figures
    leg = _named(fig, "legend").get_legend()
    labels = [t.get_text() for t in leg.get_texts()]
    assert labels[0] == "true source" and "robot" in labels and "declared source" in labels
    belief = next(i for i, lb in enumerate(labels) if lb.startswith("belief (particles"))
    # the particles' legend entry: grey markers of the weight ramp, big enough to see
    proxy = leg.legend_handles[belief]
    r, g, b = colors.to_rgb(proxy.get_color())
    assert r == g == b and proxy.get_marker() == "o" and proxy.get_markersize() >= 4
    renderer = fig.canvas.get_renderer()
    box = leg.get_window_extent(renderer)
    for name in ("map", "belief"):
        assert box.x0 > _named(fig, name).get_window_extent(renderer).x1
    # wide enough to read, whatever the dpi
    with Image.open(path) as im:
        assert im.size[0] >= viz.MIN_ANIMATION_WIDTH


def test_particle_colours_cannot_be_read_as_agents() -> None:
    rgba = viz.PARTICLE_CMAP(np.linspace(0.0, 1.0, 11))
    assert np.allclose(rgba[:, 0], rgba[:, 1]) and np.allclose(rgba[:, 1], rgba[:, 2])
    # light for the lightest weights, black for the heaviest
    assert rgba[0, 0] > 0.7 and rgba[-1, 0] == 0.0


def test_team_animation_draws_every_agents_particles_in_its_colour(tmp_path, kept_figures) -> None:
    beliefs = [(0.0, _particles(a, (2.0 + 3 * a, 3.0))) for a in range(3)]
    viz.animate(_recording(3, beliefs=beliefs), tmp_path / "team.gif", max_frames=4, dpi=40)
    (fig,) = kept_figures
    ax = _named(fig, "belief")
    clouds = [c for c in ax.collections if isinstance(c, PathCollection)]
    assert len(clouds) == 3
    for a, cloud in enumerate(clouds):
        assert len(cloud.get_offsets()) == 50
        face = cloud.get_facecolor()
        agent = np.asarray(colors.to_rgb(viz.AGENT_COLORS[a]))
        # the agent's hue, lightened towards white and transparent
        assert np.allclose(face[:, :3], 0.6 * agent + 0.4)
        assert np.all(face[:, 3] < 1.0)
    labels = [t.get_text() for t in _named(fig, "legend").get_legend().get_texts()]
    assert {"agent 0", "agent 1", "agent 2"} <= set(labels)
    assert any(lb.startswith("each agent's belief") for lb in labels)


def test_belief_map_of_a_team_draws_each_agents_belief() -> None:
    beliefs = [(5.0, _particles(a, (2.0 + 3 * a, 3.0))) for a in range(3)]
    fig = viz.plot_belief_map(_recording(3, beliefs=beliefs))
    ax = fig.axes[0]
    clouds = [c for c in ax.collections if isinstance(c, PathCollection)]
    assert len(clouds) == 3
    assert "each agent's belief" in ax.get_title()
    # each path in its agent's colour, as in the other figures
    paths = [ln for ln in ax.get_lines() if ln.get_linestyle() == "-"]
    assert [colors.to_hex(ln.get_color()) for ln in paths] == [
        colors.to_hex(c) for c in viz.AGENT_COLORS[:3]
    ]
    plt.close(fig)


def test_belief_map_equal_weights_read_on_a_zero_to_one_scale() -> None:
    fig = viz.plot_belief_map(_recording(beliefs=[(5.0, _particles(0, (5, 3), equal=True))]))
    cloud = next(c for c in fig.axes[0].collections if isinstance(c, PathCollection))
    assert cloud.get_clim() == (0.0, 1.0)
    assert np.allclose(cloud.get_array(), 1.0)
    plt.close(fig)


def test_belief_map_draws_a_grid_over_the_arena_or_says_why_not() -> None:
    prob = np.full((20, 12), 1.0 / 240)  # 0.5 m cells over the 10 m x 6 m arena
    fig = viz.plot_belief_map(_recording(beliefs=[(5.0, {"prob": prob, "agent": np.array(0)})]))
    ax = fig.axes[0]
    (img,) = [im for im in ax.get_images() if im.get_cmap().name == "magma_r"]
    assert tuple(img.get_extent()) == (0.0, 10.0, 0.0, 6.0)
    # a uniform map reads as one level on a scale from 0, not as noise around it
    assert img.norm.vmin == 0.0 and img.norm.vmax == pytest.approx(1.0 / 240)
    plt.close(fig)
    # a Dempster-Shafer map (source mass only) is drawn too
    m_s = np.zeros((20, 12))
    m_s[2, 6] = 0.8
    fig = viz.plot_belief_map(_recording(beliefs=[(5.0, {"m_s": m_s, "agent": np.array(0)})]))
    assert isinstance(fig.axes[0].get_images()[-1], AxesImage)
    plt.close(fig)
    # a grid over a smaller region whose extent is not recorded: a note, not a wrong image
    odd = np.full((30, 42), 1.0 / (30 * 42))
    fig = viz.plot_belief_map(_recording(beliefs=[(5.0, {"prob": odd, "agent": np.array(0)})]))
    ax = fig.axes[0]
    assert not [im for im in ax.get_images() if im.get_cmap().name == "magma_r"]
    assert any("not drawn" in t.get_text() for t in ax.texts)
    plt.close(fig)
    # with its recorded extent (a replayed log) it is drawn there
    snap = {"prob": odd, "lower": np.array([2.0, 1.0]), "upper": np.array([9.5, 5.2])}
    fig = viz.plot_belief_map(_recording(beliefs=[(5.0, snap)]))
    (img,) = [im for im in fig.axes[0].get_images() if im.get_cmap().name == "magma_r"]
    assert tuple(img.get_extent()) == (2.0, 9.5, 1.0, 5.2)
    plt.close(fig)
    fig = viz.plot_belief_map(_recording())
    assert any("no belief" in t.get_text() for t in fig.axes[0].texts)
    plt.close(fig)


def test_traces_name_the_agents_and_the_wind_convention() -> None:
    fig = viz.plot_traces(_recording(2))
    titles = [ax.get_title() for ax in fig.axes if ax.get_title()]
    assert titles == ["agent 0", "agent 1"]
    assert "direction in grey" in fig.get_suptitle()
    direction = next(ax for ax in fig.axes if "towards" in ax.get_ylabel())
    # wind towards -y reads -90 degrees
    assert np.allclose(direction.get_lines()[0].get_ydata(), -90.0)
    plt.close(fig)
    fig = viz.plot_traces(_recording(1))
    assert [ax.get_title() for ax in fig.axes if ax.get_title()] == ["robot"]
    plt.close(fig)


def test_key_moments_are_labelled_truthfully() -> None:
    moments = key_moments(_recording(3, dim=3, steps=21))
    assert [m[0] for m in moments] == [0.0, 10.0, 15.0, 20.0]
    labels = [m[1] for m in moments]
    assert labels == [
        "start",
        "50 % of the episode, no cue",
        "75 % of the episode, no cue",
        "end",
    ]
    det = np.zeros((21, 3), bool)
    det[4, 1] = True
    moments = key_moments(_recording(3, dim=3, steps=21, detection=det))
    assert moments[1] == (4.0, "first cue")
    assert moments[2] == (12.0, "60 % of the episode, 1 of 3 UAVs cued")
    det[6, 0] = det[8, 2] = True
    moments = key_moments(_recording(3, dim=3, steps=21, detection=det))
    assert moments[2] == (8.0, "every UAV has a cue")


def test_team_3d_panels_have_distinct_titles_and_a_cue_entry() -> None:
    beliefs = [
        (0.0, {**_particles(a, (2.0 + 3 * a, 3.0)), "positions": np.full((5, 3), 2.0)})
        for a in range(3)
    ]
    fig = plot_team_3d(_recording(3, dim=3, beliefs=beliefs, steps=21))
    titles = [ax.get_title() for ax in fig.axes]
    assert len(set(titles)) == 4 and "(c) 75 % of the episode, no cue, t = 15 s" in titles
    plt.close(fig)
    # only UAV 2 captures a cue: the legend still has its entry
    det = np.zeros((21, 3), bool)
    det[4, 1] = True
    fig = plot_team_3d(_recording(3, dim=3, steps=21, detection=det))
    assert "cue" in [t.get_text() for t in fig.legends[0].get_texts()]
    plt.close(fig)
