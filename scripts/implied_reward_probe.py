"""Which half of the model bounds imitation by reward inference: the reward a z stands for,
or the policy that should maximise it?

A z of the model stands for the implied reward r_z(s') = B(s')^T z: pi_z is trained to
maximise its discounted sum, and F(s, a, z)^T z is its predicted value. For ERFB's z (from
the task's first committed demonstration) and for z_r, the probe rolls out pi_z and
compares the mean of r_z over the states the rollout visits with its mean over the
demonstration's own states, both in units of r_z's standard deviation over the dataset:

  gap = (mean r_z over the rollout - mean r_z over the demo) / std of r_z over the data

- gap >= 0: pi_z collects at least as much of its own reward as the demonstration does,
  yet it does not do the task: the implied reward does not single out the demonstrated
  behaviour, and the bound is in B (what E_demo[B] encodes), not in F or the actor.
- gap < 0: the demonstration earns more of z's reward than pi_z does: pi_z fails to
  maximise a reward that would reward the demo's behaviour; the bound is in F or the actor
  (how well pi_z is trained for such z's).

It also prints F's value check at the rollout's start states: the predicted F(s, pi(s), z)^T
z against the discounted sum of r_z that the rollout then collects (the first `--horizon`
steps, at the model's gamma), averaged over start times 0, 100, ..., 500. A ratio far from
1 says F's values for this z are off.

Any domain; the demos folder holds <task>.npz files.

Usage: python scripts/implied_reward_probe.py MODEL --data DIR --demos DIR [--tasks all]
           [--episodes 10] [--json FILE]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import torch

from fbil.checkpoint import atomic_write_text
from fbil.data import load_dataset
from fbil.envs import get_domain, rollout
from fbil.fb.model import FBModel
from fbil.fb.policy import FBPolicy
from fbil.fb.zero_shot import dataset_backward
from fbil.imitation.core import prepare
from fbil.imitation.demos import Demos
from fbil.imitation.methods.reward import erfb

STARTS = (0, 100, 200, 300, 400, 500)


@torch.no_grad()
def value_check(model: FBModel, z: torch.Tensor, obs: np.ndarray, horizon: int) -> dict:
    """Predicted F(s_t, pi(s_t), z)^T z against the collected discounted sum of r_z from t."""
    n, steps = obs.shape[0], obs.shape[1] - 1
    starts = [t for t in STARTS if t + horizon <= steps]
    disc = model.gamma ** torch.arange(horizon, dtype=torch.float32)
    pred, real = [], []
    for t in starts:
        s = torch.as_tensor(obs[:, t], dtype=torch.float32)
        pred.append(model.q_value(s, z, model.act(s, z)))
        nxt = torch.as_tensor(obs[:, t + 1 : t + 1 + horizon], dtype=torch.float32)
        r = model.backward(nxt.reshape(-1, obs.shape[-1])).reshape(n, horizon, -1) @ z
        real.append((r * disc).sum(1))
    p, r = torch.cat(pred), torch.cat(real)
    return {"predicted": float(p.mean()), "collected": float(r.mean()), "starts": starts}


@torch.no_grad()
def probe_z(model: FBModel, z: torch.Tensor, b_data: torch.Tensor, demo_b: torch.Tensor,
            domain: str, task: str, seeds: list[int], horizon: int) -> dict:
    """One z: its rollout's return, r_z over rollout / demo / data, and F's value check."""
    episodes = rollout(domain, task, FBPolicy(model, z), seeds)
    obs = episodes.observation
    visited = torch.as_tensor(obs[:, 1:].reshape(-1, obs.shape[-1]), dtype=torch.float32)
    r_data = b_data @ z
    r_roll, r_demo = float((model.backward(visited) @ z).mean()), float((demo_b @ z).mean())
    std = float(r_data.std())
    return {
        "return_mean": float(np.mean(episodes.returns)),
        "r_z_rollout": r_roll,
        "r_z_demo": r_demo,
        "r_z_data_mean": float(r_data.mean()),
        "r_z_data_std": std,
        "r_z_data_p99": float(torch.quantile(r_data[:: max(1, len(r_data) // 200_000)], 0.99)),
        "gap": (r_roll - r_demo) / std,
        "value": value_check(model, z, obs, horizon),
    }


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("model")
    p.add_argument("--data", required=True)
    p.add_argument("--demos", required=True)
    p.add_argument("--tasks", default="all")
    p.add_argument("--episodes", type=int, default=10)
    p.add_argument("--horizon", type=int, default=300, help="steps of the value check")
    p.add_argument("--threads", type=int, default=1)
    p.add_argument("--json", default=None, help="also write the table to this JSON file")
    args = p.parse_args()
    torch.set_num_threads(args.threads)
    model, data = FBModel.load(args.model), load_dataset(args.data)
    tasks = get_domain(data.domain).task_names if args.tasks == "all" else args.tasks.split(",")
    b = dataset_backward(model, data)
    seeds = [10_000 + i for i in range(args.episodes)]
    table: dict = {"model": args.model, "data": args.data, "demos": args.demos, "tasks": {}}
    print("z      task        return  r_z: rollout    demo    data (std)     gap  value: pred / collected")
    for task in tasks:
        reward = torch.from_numpy(data.reward(task)).reshape(-1, 1).float()
        demos = Demos.load(Path(args.demos) / f"{task}.npz").select([0])
        batch = prepare(model, demos, gamma=model.gamma)
        zs = {"ERFB": erfb(model, batch)[0], "z_r": model.project_z((reward * b).mean(0))}
        row = {"demo_return": float(demos.trajectories[0].reward.sum())}
        for name, z in zs.items():
            r = probe_z(model, z, b, batch.b_next, data.domain, task, seeds, args.horizon)
            row[name] = r
            v = r["value"]
            print(
                f"{name:6} {task:10} {r['return_mean']:7.1f}  {r['r_z_rollout']:13.2f} "
                f"{r['r_z_demo']:7.2f} {r['r_z_data_mean']:7.2f} ({r['r_z_data_std']:5.2f}) "
                f"{r['gap']:7.2f}  {v['predicted']:8.1f} / {v['collected']:8.1f}",
                flush=True,
            )
        table["tasks"][task] = row
    if args.json:
        atomic_write_text(args.json, json.dumps(table, indent=1) + "\n")


if __name__ == "__main__":
    main()
