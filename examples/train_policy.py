"""Train a small NumPy-only policy in the Gymnasium environment, then evaluate it against
baselines in an ordinary odorloc sweep (same worlds for every searcher: common random numbers).

1. Training: a linear policy over the environment's observation (gas, detection, wind, position,
   heading, time; normalised by the observation bounds) chooses one of five lattice moves. The
   cross-entropy method improves it: each iteration draws candidate weight matrices, scores each
   by its mean return on the same training episodes (root seed ``--train-seed``), and refits the
   sampling distribution to the best quarter; the trained policy is the distribution's mean.
2. A registered searcher drives the same environment through ``SearcherPolicy`` (here
   ``zigzag``), for its return on the training episodes beside the trained policy's.
3. The trained policy is saved (``linear.npz``) and named in a sweep as the ``policy`` searcher
   (``callable: odorloc.searchers.policy:linear``), beside ``infotaxis``, ``zigzag`` and the
   hand-written ``upwind_surge`` policy, on episodes of another root seed (``--seed``).

    .venv/bin/python examples/train_policy.py --out odorloc-out/policy

The scenario is ``examples/policy-search.yaml`` (a small room with a meandering wind and a
source drawn anew each episode; the task is to come within 0.5 m of it). Another single-agent
scenario works the same way (``--scenario``, e.g. ``lattice-isotropic-2d``, whose moves are the
same five); to compare with another searcher add it to ``BASELINES``.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from odorloc.envs import SearchEnv, SearcherPolicy
from odorloc.experiments.stats import summarize
from odorloc.experiments.sweep import run_sweep
from odorloc.searchers.policy import LinearPolicy

HERE = Path(__file__).resolve().parent
ACTION = {"kind": "discrete", "moves": "axis", "stay": True, "declare": "none"}
BASELINES = [
    {"name": "infotaxis"},
    {"name": "zigzag"},
    {"name": "policy", "label": "upwind-surge"},
]


def normaliser(env: SearchEnv) -> tuple[np.ndarray, np.ndarray]:
    """Shift and scale from the observation bounds (unbounded readings: unit scale)."""
    lo = env.observation_space.low.astype(float)
    hi = env.observation_space.high.astype(float)
    finite = np.isfinite(lo) & np.isfinite(hi)
    shift, scale = np.zeros(len(lo)), np.ones(len(lo))
    shift[finite] = 0.5 * (lo[finite] + hi[finite])
    scale[finite] = np.maximum(0.5 * (hi[finite] - lo[finite]), 1e-9)
    names = env.feature_names
    if "gas" in names:  # readings near the detection threshold matter most
        scale[names.index("gas")] = max(env.context.gas_threshold, 1e-6) * 5.0
    return shift, scale


def episode_return(env: SearchEnv, policy: LinearPolicy, seed: int, episode: int) -> float:
    obs, _ = env.reset(seed=seed, options={"episode": episode})
    total, done = 0.0, False
    while not done:
        obs, r, term, trunc, _ = env.step(policy(obs))
        total += r
        done = term or trunc
    return total


def searcher_return(env: SearchEnv, name: str, seed: int, episode: int) -> float:
    """Return of a registered searcher driving the environment (native actions)."""
    policy = SearcherPolicy(name)
    obs, info = env.reset(seed=seed, options={"episode": episode})
    policy.reset(env)
    total, done = 0.0, False
    while not done:
        obs, r, term, trunc, info = env.step(policy(obs, info))
        total += r
        done = term or trunc
    return total


def train(
    scenario: str, iterations: int, population: int, episodes: int, seed: int
) -> tuple[LinearPolicy, list[float]]:
    env = SearchEnv(scenario, action=ACTION)
    shift, scale = normaliser(env)
    n_act, n_feat = env.action_space.n, len(shift) + 1
    rng = np.random.default_rng(seed)
    mean = np.zeros((n_act, n_feat))
    std = np.ones((n_act, n_feat))
    n_elite = max(2, population // 4)
    history: list[float] = []
    for it in range(iterations):
        cands = mean + std * rng.standard_normal((population, n_act, n_feat))
        # the same training episodes for every candidate (common random numbers)
        scores = np.array(
            [
                np.mean(
                    [
                        episode_return(env, LinearPolicy(w, shift, scale), seed, e)
                        for e in range(episodes)
                    ]
                )
                for w in cands
            ]
        )
        elite = cands[np.argsort(scores)[::-1][:n_elite]]
        mean = elite.mean(axis=0)
        std = elite.std(axis=0) + 0.2  # a floor keeps exploring
        history.append(float(np.sort(scores)[::-1][:n_elite].mean()))
        print(f"iteration {it + 1:>2}: best return {scores.max():7.1f}, elite mean "
              f"{history[-1]:7.1f}")  # fmt: skip
    # the distribution's mean: candidates' best scores are optimistic (few episodes each)
    return LinearPolicy(mean, shift, scale, "discrete"), history


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenario", default=str(HERE / "policy-search.yaml"))
    ap.add_argument("--out", type=Path, default=Path("odorloc-out/policy"))
    ap.add_argument("--iterations", type=int, default=10)
    ap.add_argument("--population", type=int, default=20)
    ap.add_argument("--train-episodes", type=int, default=6)
    ap.add_argument("--train-seed", type=int, default=1000)
    ap.add_argument("--episodes", type=int, default=40, help="evaluation episodes per searcher")
    ap.add_argument("--seed", type=int, default=2026, help="root seed of the evaluation")
    ap.add_argument("--workers", type=int, default=2)
    args = ap.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)

    t0 = time.perf_counter()
    policy, _ = train(
        args.scenario, args.iterations, args.population, args.train_episodes, args.train_seed
    )
    weights = policy.save(args.out / "linear.npz")
    print(f"trained in {time.perf_counter() - t0:.0f} s; policy saved to {weights}")
    env = SearchEnv(args.scenario, action=ACTION)
    eps = range(args.train_episodes)
    mine = np.mean([episode_return(env, policy, args.train_seed, e) for e in eps])
    zig = np.mean([searcher_return(env, "zigzag", args.train_seed, e) for e in eps])
    print(f"mean return on the training episodes: trained policy {mine:.1f}, zigzag {zig:.1f}")

    spec = {
        "name": "trained-policy-vs-baselines",
        "seed": args.seed,
        "episodes": args.episodes,
        "scenarios": [{"name": args.scenario, "label": env.core.scenario.name}],
        "searchers": [
            {
                "name": "policy",
                "label": "linear-policy",
                "params": {
                    "callable": "odorloc.searchers.policy:linear",
                    "args": {"weights": str(weights.resolve())},
                    "observation": {},  # the environment's default observation
                    "action": ACTION,
                },
            },
            *BASELINES,
        ],
    }
    store = args.out / "results.sqlite"
    df = run_sweep(spec, store, workers=args.workers, progress=False)
    table = summarize(df, time_over="all")
    print(f"{'searcher':<16} {'n':>4} {'reached':>8} {'95 % CI':>13} {'mean time s':>12}")
    for r in table.itertuples():
        label = str(r.cell_id).rsplit("/", 1)[-1]
        ci = f"[{100 * r.success_lo:.0f}, {100 * r.success_hi:.0f}] %"
        print(f"{label:<16} {r.n:>4} {100 * r.success_rate:>7.0f}% {ci:>13} {r.mean_time:>12.1f}")
    print(f"results in {store} (odorloc report {store} --out report.html)")


if __name__ == "__main__":
    main()
