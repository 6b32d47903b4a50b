"""Env-steps/s of the batched rollout engine against a plain one-environment loop.

For each domain and each policy (uniform random; a small MLP, 2x256, in PyTorch), the
baseline steps one environment at a time with one policy call per step, as a plain
Gymnasium loop does; the engine steps N environments in lockstep with one batched policy
call per step. Both are measured in the same run, on the same number of env-steps.

    python benchmarks/rollout.py [--steps 200] [--domains walker,cheetah] [--json]
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np
import torch

from fbil.envs import DOMAINS, BatchedEnv, RandomPolicy, make_env


class MLPPolicy:
    def __init__(self, obs_dim: int, act_dim: int) -> None:
        torch.manual_seed(0)
        self.net = torch.nn.Sequential(
            torch.nn.Linear(obs_dim, 256),
            torch.nn.ReLU(),
            torch.nn.Linear(256, 256),
            torch.nn.ReLU(),
            torch.nn.Linear(256, act_dim),
            torch.nn.Tanh(),
        ).eval()

    @torch.no_grad()
    def __call__(self, obs: np.ndarray, step: int) -> np.ndarray:
        return self.net(torch.from_numpy(obs)).numpy()


def plain_loop(domain: str, task: str, policy, episodes: int, steps: int) -> float:
    env = make_env(domain, task)
    t0 = time.perf_counter()
    for ep in range(episodes):
        obs, _ = env.reset(seed=ep)
        for t in range(steps):
            obs, *_ = env.step(policy(obs[None], t)[0])
    return episodes * steps / (time.perf_counter() - t0)


def batched(domain: str, task: str, policy, n: int, steps: int) -> float:
    env = BatchedEnv(domain, task, n)
    t0 = time.perf_counter()
    env.rollout(policy, list(range(n)), steps)
    return n * steps / (time.perf_counter() - t0)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--steps", type=int, default=200, help="steps per episode")
    parser.add_argument("--sizes", default="1,8,32")
    parser.add_argument("--domains", default=",".join(DOMAINS))
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    sizes = [int(s) for s in args.sizes.split(",")]
    results: dict[str, dict[str, dict[str, float]]] = {}
    for domain in args.domains.split(","):
        spec = DOMAINS[domain]
        task = spec.task_names[0]
        results[domain] = {}
        for name, make_policy in (
            ("random", lambda spec=spec: RandomPolicy(spec.act_dim, seed=0)),
            ("mlp", lambda spec=spec: MLPPolicy(spec.obs_dim, spec.act_dim)),
        ):
            # Same total env-steps for the baseline as for the largest batch.
            row = {"plain_loop": plain_loop(domain, task, make_policy(), max(sizes), args.steps)}
            for n in sizes:
                row[f"batched_n{n}"] = batched(domain, task, make_policy(), n, args.steps)
            results[domain][name] = row
    if args.json:
        print(json.dumps({"threads": torch.get_num_threads(), "results": results}))
        return
    print(f"env-steps/s (torch threads: {torch.get_num_threads()}; x = ratio to plain loop)")
    header = f"{'domain':<16}{'policy':<8}{'plain loop':>12}" + "".join(
        f"{'N=' + str(n):>18}" for n in sizes
    )
    print(header)
    print("-" * len(header))
    for domain, by_policy in results.items():
        for name, row in by_policy.items():
            base = row["plain_loop"]
            cells = "".join(
                f"{row[f'batched_n{n}']:>10.0f} ({row[f'batched_n{n}'] / base:4.2f}x)"
                for n in sizes
            )
            print(f"{domain:<16}{name:<8}{base:>12.0f}{cells}")


if __name__ == "__main__":
    main()
