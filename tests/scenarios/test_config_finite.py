"""Values that cannot run are refused when the scenario is loaded and checked, naming the field:
NaN and infinities, true/false inside lists of numbers, and settings whose trouble used to show
only inside an episode (a source-draw box, a filament release too large for one step, a
lattice plume's first hit without a rate). On the command line: exit 2, one line, nothing run.
"""

from __future__ import annotations

import copy
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from typer.testing import CliRunner

from helpers import filament_scenario_dict, small_scenario_dict
from odorloc.cli import app
from odorloc.core.errors import ConfigError
from odorloc.scenarios.loading import check_scenario, load_scenario

NAN, INF = math.nan, math.inf


def _set(data: dict[str, Any], dotted: str, value: Any) -> None:
    keys = dotted.split(".")
    node: Any = data
    for k in keys[:-1]:
        node = node[int(k)] if isinstance(node, list) else node.setdefault(k, {})
    if isinstance(node, list):
        node[int(keys[-1])] = value
    else:
        node[keys[-1]] = value


def _lattice_rate_zero() -> dict[str, Any]:
    d = load_scenario("lattice-isotropic-2d").to_dict()
    d["world"]["sources"][0]["rate"] = 0.0
    return d


def _filament(**sets: Any) -> dict[str, Any]:
    d = filament_scenario_dict("zigzag")
    for k, v in sets.items():
        _set(d, k.replace("__", "."), v)
    return d


def _small(searcher: str = "zigzag", **sets: Any) -> dict[str, Any]:
    d = small_scenario_dict(searcher)
    for k, v in sets.items():
        _set(d, k.replace("__", "."), v)
    return d


def _draw(region: Any) -> dict[str, Any]:
    return _small(world__source_draw={"type": "uniform", "region": region})


# (id, scenario as a plain dict, the start of the one error line after "error: ")
CASES: list[tuple[str, dict[str, Any], str]] = [
    # ---------------------------------------------------------------- NaN and infinities
    (
        "modulation-phase-nan",
        _small(
            world__sources=[
                {"position": [1.0, 2.5], "rate": 1.0, "modulation": {"kind": "sine", "phase": NAN}}
            ]
        ),
        "world.sources[0].modulation.phase: must be finite",
    ),
    (
        "modulation-phase-inf",
        _small(
            world__sources=[
                {"position": [1.0, 2.5], "rate": 1.0, "modulation": {"kind": "onoff", "phase": INF}}
            ]
        ),
        "world.sources[0].modulation.phase: must be finite",
    ),
    (
        "surge-cast-threshold-nan",
        _small("surge-cast", searcher__threshold=NAN),
        "searcher.threshold: must be finite",
    ),
    (
        "chemotaxis-threshold-inf",
        _small("chemotaxis", searcher__threshold=INF),
        "searcher.threshold: must be finite",
    ),
    (
        "anemotaxis-threshold-minus-inf",
        _small("anemotaxis", searcher__threshold=-INF),
        "searcher.threshold: must be finite",
    ),
    (
        "start-points-nan",
        _small(agents__start_points=[[NAN, 1.0]]),
        "agents.start_points[0]: all components must be finite",
    ),
    (
        "start-sets-nan",
        _small(agents__start_sets={"A": [[NAN, 1.0]]}),
        "agents.start_sets.A[0]: all components must be finite",
    ),
    (
        "starts-inf",
        _small(agents__starts=[[INF, 2.0]]),
        "agents.starts[0]: all components must be finite",
    ),
    (
        "surge-cast-cast-growth-inf",
        _small("surge-cast", searcher__cast__growth=INF),
        "searcher.cast.growth: must be finite",
    ),
    (
        "gradient-bionic-cast-growth-inf",
        _small("gradient-bionic", searcher__cast__growth=INF),
        "searcher.cast.growth: must be finite",
    ),
    (
        "surge-spiral-increment-inf",
        _small("surge-spiral", searcher__spiral__step_increment=INF),
        "searcher.spiral.step_increment: must be a finite number >= 0",
    ),
    (
        "random-walk-turn-std-inf",
        _small("random-walk", searcher__turn_std_deg=INF),
        "searcher.turn_std_deg: must be a finite number >= 0",
    ),
    (
        "rectangular-wave-margin-inf",
        _small("rectangular-wave", searcher__margin=INF),
        "searcher.margin: must be a finite number >= 0",
    ),
    (
        "spiral-increment-inf",
        _small("spiral", searcher__step_increment=INF),
        "searcher.step_increment: must be a finite number >= 0",
    ),
    (
        "spiral-kmu-inf",
        _small("spiral", searcher__kmu=INF),
        "searcher.kmu: must be a finite number >= 0",
    ),
    # ---------------------------------------------------------------- true/false in lists
    (
        "arena-lower-false",
        _small(world__arena__lower=[False, 0.0]),
        "world.arena.lower[0]: must be a number, not false",
    ),
    (
        "arena-upper-true",
        _small(world__arena__upper=[10.0, True]),
        "world.arena.upper[1]: must be a number, not true",
    ),
    (
        "obstacle-box-true",
        _small(world__arena__obstacles={"boxes": [[[True, 1.0], [2.0, 2.0]]]}),
        "world.arena.obstacles.boxes[0][0][0]: must be a number, not true",
    ),
    (
        "obstacle-polygon-true",
        _small(world__arena__obstacles={"polygons": [[[4.0, 1.0], [5.0, True], [4.5, 3.0]]]}),
        "world.arena.obstacles.polygons[0][1][1]: must be a number, not true",
    ),
    (
        "group-agent-false",
        _small(agents__groups=[{"name": "a", "agents": [False]}]),
        "agents.groups[0].agents[0]: must be a number, not false",
    ),
    (
        "optional-number-true",
        _small(task={"end": "reach", "reach_radius": True}),
        "task.reach_radius: must be a number, not true",
    ),
    (
        "source-draw-region-true",
        _draw([[1.0, True], [3.5, 5.0]]),
        "world.source_draw.region[0][1]: must be a number, not true",
    ),
    # ---------------------------------------------------------------- found before any episode
    (
        "source-draw-region-nan",
        _draw([[NAN, 1.0], [3.5, 5.0]]),
        "world.source_draw.region: corners must be finite",
    ),
    (
        "source-draw-region-inverted",
        _draw([[3.5, 5.0], [1.0, 1.0]]),
        "world.source_draw.region: upper corner (1.0, 1.0) must exceed lower (3.5, 5.0)",
    ),
    (
        "source-draw-region-3d-in-2d",
        _draw([[1.0, 1.0, 0.0], [3.0, 3.0, 1.0]]),
        "world.source_draw.region: has more components than the 2D arena",
    ),
    (
        "source-draw-region-outside",
        _draw([[20.0, 20.0], [30.0, 30.0]]),
        "world.source_draw.region: does not overlap the arena",
    ),
    (
        "filament-rate-huge",
        _filament(world__sources=[{"position": [1.0, 2.5], "rate": 1.0e9}]),
        "world.sources[0].rate: releases 1e+08 filaments in one 0.1 s step; at most "
        "world.plume.max_filaments (100000)",
    ),
    (
        # 80 filaments per step on average, 120 at the sine's peak
        "filament-rate-at-modulation-peak",
        _filament(
            world__plume={"type": "filament", "max_filaments": 100},
            world__sources=[
                {
                    "position": [1.0, 2.5],
                    "rate": 800.0,
                    "modulation": {"kind": "sine", "depth": 0.5},
                }
            ],
        ),
        "world.sources[0].rate: releases 120 filaments in one 0.1 s step",
    ),
    (
        "lattice-initial-hit-rate-zero",
        _lattice_rate_zero(),
        "world.sources[0].rate: initial-hit needs a positive rate",
    ),
]


def _write(tmp_path: Path, data: dict[str, Any]) -> Path:
    f = tmp_path / "s.yaml"
    f.write_text(yaml.safe_dump(data, sort_keys=False))
    return f


@pytest.fixture
def no_episode(monkeypatch: pytest.MonkeyPatch) -> None:
    """Fail the test if an episode starts."""
    import odorloc.engine.episode as episode

    def refuse(*args: Any, **kwargs: Any) -> Any:
        raise AssertionError("an episode ran")

    monkeypatch.setattr(episode, "run_episode", refuse)


@pytest.mark.parametrize(("data", "expect"), [c[1:] for c in CASES], ids=[c[0] for c in CASES])
def test_check_names_the_field(data: dict[str, Any], expect: str, tmp_path: Path) -> None:
    with pytest.raises(ConfigError) as err:
        check_scenario(load_scenario(_write(tmp_path, copy.deepcopy(data))))
    assert str(err.value).startswith(expect), str(err.value)


@pytest.mark.parametrize(("data", "expect"), [c[1:] for c in CASES], ids=[c[0] for c in CASES])
def test_run_refuses_before_any_episode(
    data: dict[str, Any], expect: str, tmp_path: Path, no_episode: None
) -> None:
    f = _write(tmp_path, copy.deepcopy(data))
    out = tmp_path / "out"
    r = CliRunner().invoke(app, ["run", str(f), "--out", str(out), "--no-animation"])
    if r.exception is not None and not isinstance(r.exception, SystemExit):
        raise r.exception
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert r.exit_code == 2, r.output
    assert len(lines) == 1 and lines[0].startswith(f"error: {expect}"), r.stderr
    assert "Traceback" not in r.output
    assert not out.exists()


@pytest.mark.parametrize(
    ("scenario", "params", "expect"),
    [
        (
            "lattice-isotropic-2d",
            {"world.sources.0.rate": 0.0},
            "scenarios[0].params.world.sources.0.rate: initial-hit needs a positive rate",
        ),
        ("s.yaml", {}, "world.source_draw.region: upper corner"),
    ],
    ids=["lattice-rate-zero", "source-draw-region-inverted"],
)
def test_batch_refuses_before_any_episode(
    scenario: str, params: dict[str, Any], expect: str, tmp_path: Path
) -> None:
    _write(tmp_path, _draw([[3.5, 5.0], [1.0, 1.0]]))
    sweep = {
        "name": "t",
        "seed": 1,
        "episodes": 1,
        "scenarios": [{"name": scenario, "params": params}],
        "searchers": [{"name": "infotaxis" if scenario.startswith("lattice") else "zigzag"}],
    }
    f = tmp_path / "sweep.yaml"
    f.write_text(yaml.safe_dump(sweep))
    out = tmp_path / "out"
    r = CliRunner().invoke(app, ["batch", str(f), "--out", str(out), "--no-progress"])
    if r.exception is not None and not isinstance(r.exception, SystemExit):
        raise r.exception
    assert r.exit_code == 2, r.output
    assert r.stderr.strip().startswith(f"error: {expect}"), r.stderr
    assert len(r.stderr.strip().splitlines()) == 1
    assert not out.exists()


# ----------------------------------------------------------------------------- the parts


def test_lists_refuse_bools_but_take_ints_and_keep_point_messages() -> None:
    from odorloc.scenarios.config import Scenario

    d = _small(
        world__arena__lower=[0, 0],
        world__arena__obstacles={
            "boxes": [[[4, 1], [5.0, 2]]],
            "polygons": [[[6.0, 3.0], [7, 3], [6.5, 4]]],
        },
        agents__groups=[{"name": "a", "agents": [0]}],
    )
    sc = Scenario.from_dict(d)
    assert sc.world.arena.lower == (0.0, 0.0)
    assert sc.world.arena.obstacles.boxes[0] == ((4.0, 1.0), (5.0, 2.0))
    assert sc.agents.groups[0].agents == [0]
    check_scenario(sc)
    d["world"]["arena"]["obstacles"]["boxes"][0][1][1] = False
    with pytest.raises(ConfigError, match=r"boxes\[0\]\[1\]\[1\]: must be a number, not false"):
        Scenario.from_dict(d)
    # points keep the message of their own check
    with pytest.raises(ConfigError, match=r"agents\.starts\[0\]: components must be numbers"):
        Scenario.from_dict(_small(agents__starts=[[True, 2.5]]))


def test_params_name_the_item_of_a_nested_list() -> None:
    from odorloc.core.registry import make_params

    with pytest.raises(ConfigError) as err:
        make_params("searcher", "rectangular-wave", {"region": [[0, 0], [5, False]]}, "searcher")
    assert str(err.value) == "searcher.region[1][1]: must be a number, not false"


def test_filament_step_check_and_mid_run_guard_agree() -> None:
    from odorloc.scenarios.build import build_world
    from odorloc.scenarios.config import Scenario

    ok = Scenario.from_dict(
        _filament(
            world__plume={"type": "filament", "max_filaments": 100},
            world__sources=[{"position": [1.0, 2.5], "rate": 900.0}],
        )
    )
    w = build_world(ok)  # 90 per step: within the cap
    with pytest.raises(ConfigError, match=r"world\.sources\[0\]\.rate: releases 180 filaments"):
        w.plume.check_step(0.2)
    w.reset(np.random.default_rng(0))
    w.step(0.1, np.random.default_rng(1))
    # a longer step than the scenario's is still refused when it is taken
    with pytest.raises(ConfigError, match=r"world\.sources\[0\]\.rate: releases 180 filaments"):
        w.step(0.2, np.random.default_rng(1))
