"""What an expert does, in the terms of its task's reward: the physical quantities the
domain's rewards read (walker: torso height, uprightness, speed, angular momentum), per
step over a few episodes of the expert, summarised by mean and percentiles.

    python scripts/task_quantities.py EXPERT_DIR [--episodes 2] [--seed 0] [--json]

Use it when an expert plateaus below the paper's return: it shows which factor of the
reward is lost (e.g. a flip expert that rocks back and forth has a median angular momentum
at the threshold but large negative swings).
"""

from __future__ import annotations

import argparse
import json

import numpy as np
import torch

from fbil.agents.expert import load_expert
from fbil.envs.env import make_env


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("expert", help="folder of `fbil expert` (expert.json + best.safetensors)")
    parser.add_argument("--episodes", type=int, default=2)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    torch.set_num_threads(1)
    agent, meta = load_expert(args.expert)
    env = make_env(meta["domain"], meta["task"], seed=args.seed)
    rows: list[dict[str, float]] = []
    returns = []
    for episode in range(args.episodes):
        obs, _ = env.reset(seed=args.seed + episode)
        total, done = 0.0, False
        while not done:
            obs, reward, _, done, _ = env.step(agent.act(obs[None])[0])
            total += float(reward)
            q = env.domain.read_quantities(env.physics)
            rows.append({k: float(np.asarray(v).ravel()[0]) for k, v in q.items()})
        returns.append(total)
    summary = {
        name: {
            "mean": round(float(np.mean(col)), 3),
            **{f"p{p}": round(float(np.percentile(col, p)), 3) for p in (10, 50, 90)},
        }
        for name, col in ((k, [r[k] for r in rows]) for k in rows[0])
    }
    result = {"domain": meta["domain"], "task": meta["task"], "returns": returns, **summary}
    if args.json:
        print(json.dumps(result))
        return
    print(f"{meta['domain']}/{meta['task']}: returns {', '.join(f'{r:.1f}' for r in returns)}")
    for name, s in summary.items():
        print(
            f"  {name:<22} mean {s['mean']:>8}  "
            + "  ".join(f"{p} {s[p]:>8}" for p in ("p10", "p50", "p90"))
        )


if __name__ == "__main__":
    main()
