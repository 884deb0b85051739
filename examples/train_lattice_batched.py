"""Train a linear policy on the batched lattice environment, and say how long it took.

The environment is :class:`odorloc.envs.vector.LatticeVectorEnv` on ``lattice-isotropic-2d``
(OTTO's 2-D problem, N = 19): thousands of episodes stepped at once as arrays. The policy picks
the move with the largest score ``W @ [features, 1]`` over the four lattice moves. The
cross-entropy method improves ``W``: each iteration draws ``--population`` candidate matrices,
lets every candidate drive its own block of ``--episodes`` sub-environments for ``--horizon``
steps (all candidates in one vector environment, same root seed every iteration: common random
numbers), scores a candidate by its mean reward per step (-1 per step, +100 on reaching the
source), and refits the sampling distribution to the best quarter.

The mean reward per step of the trained policy is printed beside a uniform random policy and
the "greedy" rule (move to the neighbouring cell the belief likes most), on another root seed.

    .venv/bin/python examples/train_lattice_batched.py [--iterations 15] [--quick]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from odorloc.envs.vector import LatticeVectorEnv


def rollout(env: LatticeVectorEnv, policy, horizon: int, seed: int) -> np.ndarray:  # type: ignore[no-untyped-def]
    """Mean reward per step of every sub-environment over ``horizon`` steps, ``(B,)``."""
    obs, _ = env.reset(seed=seed)
    total = np.zeros(env.num_envs)
    for _ in range(horizon):
        obs, r, *_ = env.step(policy(obs))
        total += r
    return total / horizon


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--iterations", type=int, default=15)
    ap.add_argument("--population", type=int, default=32)
    ap.add_argument("--episodes", type=int, default=64, help="sub-environments per candidate")
    ap.add_argument("--horizon", type=int, default=200)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--quick", action="store_true", help="a few small iterations")
    args = ap.parse_args(argv)
    if args.quick:
        args.iterations, args.population, args.episodes, args.horizon = 2, 8, 8, 30
    pop, eps = args.population, args.episodes
    env = LatticeVectorEnv("lattice-isotropic-2d", num_envs=pop * eps)
    f = env.single_observation_space.shape[0] + 1
    moves = int(env.single_action_space.n)
    rng = np.random.default_rng(args.seed)
    mean, std = np.zeros((moves, f)), np.ones((moves, f))

    def block_policy(ws: np.ndarray):  # type: ignore[no-untyped-def]
        def act(obs: np.ndarray) -> np.ndarray:
            x = np.concatenate([obs, np.ones((len(obs), 1), np.float32)], axis=1)
            scores = np.einsum("pmf,pef->pem", ws, x.reshape(pop, eps, f))
            return scores.argmax(axis=2).reshape(-1)

        return act

    t0 = time.perf_counter()
    steps = 0
    for it in range(args.iterations):
        ws = mean + std * rng.standard_normal((pop, moves, f))
        score = rollout(env, block_policy(ws), args.horizon, args.seed).reshape(pop, eps).mean(1)
        steps += env.num_envs * args.horizon
        elite = ws[np.argsort(score)[-max(2, pop // 4) :]]
        mean, std = elite.mean(axis=0), elite.std(axis=0) + 0.05
        print(f"iteration {it + 1:>2}: best {score.max():+.3f}, mean {score.mean():+.3f} per step")
    wall = time.perf_counter() - t0
    print(
        f"trained in {wall:.1f} s: {steps:,} agent-steps ({steps / wall:,.0f} per second), "
        f"{args.iterations} iterations of {pop} candidates x {eps} episodes"
    )

    test = LatticeVectorEnv("lattice-isotropic-2d", num_envs=pop * eps)
    d = env.problem.dim
    z = env.problem.z
    near = slice(d + z + 1, d + z + 1 + 2 * d)  # the belief in the neighbouring cells
    policies = {
        "trained": block_policy(np.broadcast_to(mean, (pop, moves, f))),
        "random": lambda o: rng.integers(0, moves, len(o)),
        "greedy": lambda o: o[:, near].argmax(axis=1),
    }
    print(f"mean reward per step on root seed {args.seed + 1} ({pop * eps} episodes):")
    for name, pol in policies.items():
        print(f"  {name:<8} {rollout(test, pol, args.horizon, args.seed + 1).mean():+.3f}")


if __name__ == "__main__":
    main()
