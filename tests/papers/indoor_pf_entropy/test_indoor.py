"""End-to-end episodes of the indoor PF paper's scenarios."""

from __future__ import annotations

import numpy as np

from odorloc.core.seeds import episode_seeds
from odorloc.engine.episode import run_episode
from odorloc.experiments.runner import cell_scenario
from odorloc.scenarios.build import build_arena


def test_seeded_pf_episode_localises_the_source() -> None:
    sc = cell_scenario({"scenario": "indoor-ventilated", "scenario_params": {"start_index": 4}})
    res = run_episode(sc, *episode_seeds(2024, "indoor-ventilated", 0))
    m = res.metrics
    assert m["termination"] == "declared" and m["success"]
    assert m["loc_error"] <= 0.5
    # Entropy of the source posterior fell between initialisation and declaration.
    assert m["entropy_end"] < m["entropy_init"]
    assert np.isfinite(m["first_detection_time"]) and m["first_detection_time"] < m["search_time"]


def test_robot_never_enters_furniture() -> None:
    sc = cell_scenario({"scenario": "indoor-obstacles", "scenario_params": {"start_index": 4}})
    arena = build_arena(sc.world.arena)
    for ep in range(2):
        rec = run_episode(sc, *episode_seeds(7, "indoor-ventilated", ep)).recording
        assert rec is not None
        assert not arena.in_obstacle(rec.positions[:, 0]).any()
        # Every straight segment between recorded positions stays free (no corner cutting).
        p = rec.positions[:, 0]
        assert arena.segment_free(p[:-1], p[1:]).all()


def test_pf_and_gradient_face_the_same_plume() -> None:
    """Common random numbers: the same episode index gives both methods the same world."""
    frames = []
    for searcher in ("pf-entropy", "gradient-bionic"):
        sc = cell_scenario({"scenario": "indoor-ventilated", "searcher": searcher})
        sc = sc.with_overrides({"limits.time": 20.0})
        frames.append(
            run_episode(sc, *episode_seeds(1, "indoor-ventilated", 5)).recording.plume_frames
        )
    assert np.array_equal(frames[0], frames[1])


def test_particle_snapshots_run_only_the_stored_episode(tmp_path, monkeypatch) -> None:
    """The snapshots of a one-episode sweep whose only PF episode failed show that episode (at
    the end), run once with its stored seeds, and it repeats the stored row; no episode beyond
    the stored ones runs (root seed 22: episode 0 of start 4 declares outside the 0.5 m)."""
    import odorloc.engine.episode as episode_mod
    import odorloc.papers.indoor_pf_entropy.reproduction as ind
    from odorloc.experiments.sweep import run_sweep

    spec = {
        "name": "snapshots",
        "seed": 22,
        "episodes": 1,
        "scenarios": [{"name": "indoor-ventilated", "grid": {"start_index": [4]}}],
        "searchers": [{"name": "pf-entropy"}],
    }
    store = tmp_path / "results.sqlite"
    df = run_sweep(spec, store, workers=1, progress=False, summary=False)
    assert len(df) == 1 and not bool(df.success.iloc[0])
    calls = []
    real = episode_mod.run_episode

    def counted(sc, world_seed, agent_seed, **kw):
        calls.append((world_seed, agent_seed))
        return real(sc, world_seed, agent_seed, **kw)

    monkeypatch.setattr(episode_mod, "run_episode", counted)
    changed = ind.episode_figures(df, store, tmp_path / "particle_snapshots.png")
    assert calls == [(int(df.world_seed.iloc[0]), int(df.agent_seed.iloc[0]))]
    assert changed == []
    for name in ("particle_snapshots.png", "entropy_curve.png", "traces.png"):
        assert (tmp_path / name).stat().st_size > 0


def testsnapshot_episode_is_the_first_stored_success_of_the_farthest_pf_start() -> None:
    import pandas as pd

    from odorloc.papers.indoor_pf_entropy.reproduction import snapshot_episode

    def row(searcher: str, start: int, ep: int, success: bool | None, status: str = "ok"):
        return {
            "cell_id": f"indoor-ventilated[start_index={start}]/{searcher}",
            "searcher": searcher,
            "scenario.start_index": start,
            "episode": ep,
            "success": success,
            "status": status,
        }

    rows = [
        row("pf-entropy", 4, 0, None, "error"),
        row("pf-entropy", 4, 1, False),
        row("pf-entropy", 4, 3, True),
        row("pf-entropy", 4, 2, True),
        row("pf-entropy", 2, 0, True),
        row("pf-entropy-literal", 4, 0, True),
    ]
    df = pd.DataFrame(rows).astype({"success": "boolean"})
    assert snapshot_episode(df) == ("indoor-ventilated[start_index=4]/pf-entropy", 2)
    # no success: the first episode that ran; nothing that ran: none
    assert snapshot_episode(df.iloc[:2]) == ("indoor-ventilated[start_index=4]/pf-entropy", 1)
    assert snapshot_episode(df.iloc[:1]) is None


def test_entropy_table_reports_start_end_and_share_that_fell() -> None:
    """The entropy table averages start and end over the PF episodes whose filter started and
    counts those where it fell, with intervals; the hybrid's rows (no filter) are left out."""
    import pandas as pd

    from odorloc.experiments import reproduction as rp
    from odorloc.papers.indoor_pf_entropy.reproduction import METHODS

    rows = []
    for start in range(5):
        for ep in range(4):
            for k, searcher in enumerate(METHODS):
                pf = searcher != "gradient-bionic"
                # episode 3 of the PF never detected: no filter, no entropy
                h0 = 4.0 + 0.1 * ep if pf and ep < 3 else np.nan
                # entropy rose in episode 0 of start 0 only
                h1 = h0 + 0.5 if (start, ep) == (0, 0) else h0 - 2.0
                rows.append(
                    {
                        "cell_id": f"indoor-ventilated[start_index={start}]/{searcher}",
                        "cell_index": 3 * start + k,
                        "world_key": f"indoor-ventilated[start_index={start}]",
                        "scenario": "indoor-ventilated",
                        "searcher": searcher,
                        "scenario.start_index": start,
                        "episode": ep,
                        "status": "ok",
                        "success": True,
                        "search_time": 100.0,
                        "loc_error": 0.1,
                        "path_length": 10.0,
                        "start_distance": 4.0,
                        "entropy_init": h0,
                        "entropy_end": h1,
                    }
                )
    df = pd.DataFrame(rows).astype({"success": "boolean"})
    tabs = {t.name: t for t in rp.get("indoor-pf-entropy").tables(df, 1)}
    ent = tabs["entropy"]
    by = {(r[0], r[1]): r for r in ent.rows}
    assert set(by) == {
        (s, m)
        for s in ("all", "0", "1", "2", "3", "4")
        for m in ("pf-entropy", "pf-entropy-literal")
    }
    _, _, n, h0, h1, fell, paper = by[("all", "pf-entropy")]
    assert n == "15"
    assert h0.startswith("4.10 [") and h1.startswith(f"{(4.1 * 15 - 2.0 * 14 + 0.5) / 15:.2f} [")
    assert fell.startswith("93 [")  # 14 of 15
    assert paper == "falls"
    assert by[("0", "pf-entropy")][5].startswith("67 [") and by[("1", "pf-entropy")][5] == (
        "100 [44, 100]"
    )
    # deterministic for a seed
    again = {t.name: t for t in rp.get("indoor-pf-entropy").tables(df, 1)}["entropy"]
    assert again.rows == ent.rows
