"""Evaluation throughput: the batched evaluation against one episode at a time.

Plays M imitation policies (random z on the sphere of an FB model; default the committed
maze model) for E episodes each, on one maze task: once with `rollout_policies` (all
M x E environments in lockstep, one policy call per step), once as a plain loop over
policies and episodes (one Gymnasium environment, one policy call per step). Both in the
same run; env-steps/s and their ratio are printed.

    python benchmarks/evaluation.py [--model DIR] [--policies 8] [--episodes 20] [--json]
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
import torch

from fbil.envs import make_env
from fbil.evaluation.evaluate import rollout_policies
from fbil.fb.model import FBModel
from fbil.imitation import ImitationPolicy

ROOT = Path(__file__).resolve().parents[1]


def one_at_a_time(policies: list[ImitationPolicy], task: str, episodes: int) -> float:
    env = make_env("point_mass_maze", task)
    returns = []
    for p in policies:
        for i in range(episodes):
            obs, _ = env.reset(seed=i)
            total, done, t = 0.0, False, 0
            while not done:
                obs, r, term, trunc, _ = env.step(p.act(obs[None], t)[0])
                total, done, t = total + float(r), term or trunc, t + 1
            returns.append(total)
    return float(np.mean(returns))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--model", default=str(ROOT / "artifacts/models/point_mass_maze"))
    parser.add_argument("--task", default="loop")
    parser.add_argument("--policies", type=int, default=8)
    parser.add_argument("--episodes", type=int, default=20)
    parser.add_argument("--threads", type=int, default=None)
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    if args.threads:
        torch.set_num_threads(args.threads)
    model = FBModel.load(args.model)
    gen = torch.Generator().manual_seed(0)
    policies = [
        ImitationPolicy(model, "random-z", model.sample_z(1, gen)[0]) for _ in range(args.policies)
    ]
    steps = args.policies * args.episodes * 1000
    t0 = time.perf_counter()
    rollout_policies(policies, "point_mass_maze", args.task, args.episodes)
    batched = steps / (time.perf_counter() - t0)
    # The loop is slow: time a tenth of the episodes and report the rate.
    loop_episodes = max(1, args.episodes // 10)
    t0 = time.perf_counter()
    one_at_a_time(policies, args.task, loop_episodes)
    loop = args.policies * loop_episodes * 1000 / (time.perf_counter() - t0)
    result = {
        "policies": args.policies,
        "episodes": args.episodes,
        "threads": torch.get_num_threads(),
        "batched_steps_per_s": round(batched),
        "loop_steps_per_s": round(loop),
        "ratio": round(batched / loop, 2),
    }
    if args.json:
        print(json.dumps(result))
        return
    print(
        f"{args.policies} policies x {args.episodes} episodes of maze/{args.task}, "
        f"{result['threads']} threads"
    )
    print(f"batched evaluation: {batched:>9.0f} env-steps/s")
    print(f"one at a time:      {loop:>9.0f} env-steps/s")
    print(f"ratio:              {batched / loop:>9.2f}x")


if __name__ == "__main__":
    main()
