"""Which half of the model bounds imitation by reward inference: the reward a z stands for,
or the policy that should maximise it?

A z of the model stands for an implied reward: F(s, a, z)^T z, which pi_z maximises, is the
value of r_z(s') = B(s')^T C^-1 z, with C = E_rho[B B^T] the model's `cov_b` (the successor
measure is F^T B; the value of a reward r is F^T E_rho[B r], and E_rho[B B^T C^-1 z] = z).
With `--plain`, r_z = B^T z instead (the same when B is orthonormal, C = I). For ERFB's z (from
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

And it splits a policy bound between F and the actor, at the demo's states and at the
rollout's: `actor_gap` is the mean over states of max_a Q(s, a) - Q(s, pi(s)), the max over
`--actions` uniform random actions and the demo's own action, in units of Q's standard
deviation over those actions (Q = F(s, a, z)^T z). Near 0 or below: the actor finds F's
best actions, so F's values are what keep pi_z from the demo's reward (a bound in F);
clearly above 0: F knows better actions than the actor takes (a bound in the actor).
`demo_adv` is the mean of Q(s, a_demo) - Q(s, pi(s)) over the demo's states, same units.
`saturated` is the share of the actor's action coordinates beyond 0.99 in absolute value.
`actor_gap_local` is the same as `actor_gap` over `--actions` perturbations of the actor's
own action (Gaussian, std 0.2, clipped): in many action dimensions uniform random actions
are a weak search, and this checks the actor's local optimality instead.

Any domain; the demos folder holds <task>.npz files.

Usage: python scripts/implied_reward_probe.py MODEL --data DIR --demos DIR [--tasks all]
           [--episodes 10] [--json FILE]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

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
HEADER = (
    "z      task        return  r_z: rollout    demo    data (std)     gap"
    "  value: pred / collected  actor_gap demo / rollout  demo_adv  local demo / rollout"
)


def row_text(name: str, task: str, r: dict) -> str:
    """One printed line of the table."""
    v, d, o = r["value"], r["at_demo"], r["at_rollout"]
    return (
        f"{name:6} {task:10} {r['return_mean']:7.1f}  {r['r_z_rollout']:13.2f} "
        f"{r['r_z_demo']:7.2f} {r['r_z_data_mean']:7.2f} ({r['r_z_data_std']:5.2f}) "
        f"{r['gap']:7.2f}  {v['predicted']:8.1f} / {v['collected']:8.1f}"
        f"  {d['actor_gap']:6.2f} / {o['actor_gap']:6.2f}  {d.get('demo_adv', float('nan')):6.2f}"
        f"  {d['actor_gap_local']:6.2f} / {o['actor_gap_local']:6.2f}"
    )


def implied_reward_weights(model: Any, z: torch.Tensor, plain: bool = False) -> torch.Tensor:
    """w with r_z(s') = B(s')^T w the reward whose value F(s, a, z)^T z is: C^-1 z, with
    C = E_rho[B B^T] the model's `cov_b` (z itself with `plain`)."""
    if plain:
        return z
    return torch.linalg.solve(model.cov_b.double(), z.double()).to(z.dtype)


@torch.no_grad()
def value_check(
    model: FBModel, z: torch.Tensor, w: torch.Tensor, obs: np.ndarray, horizon: int
) -> dict:
    """Predicted F(s_t, pi(s_t), z)^T z against the collected discounted sum of r_z = B^T w."""
    n, steps = obs.shape[0], obs.shape[1] - 1
    starts = [t for t in STARTS if t + horizon <= steps]
    disc = model.gamma ** torch.arange(horizon, dtype=torch.float32)
    pred, real = [], []
    for t in starts:
        s = torch.as_tensor(obs[:, t], dtype=torch.float32)
        pred.append(model.q_value(s, z, model.act(s, z)))
        nxt = torch.as_tensor(obs[:, t + 1 : t + 1 + horizon], dtype=torch.float32)
        r = model.backward(nxt.reshape(-1, obs.shape[-1])).reshape(n, horizon, -1) @ w
        real.append((r * disc).sum(1))
    p, r = torch.cat(pred), torch.cat(real)
    return {"predicted": float(p.mean()), "collected": float(r.mean()), "starts": starts}


@torch.no_grad()
def probe_z(
    model: FBModel,
    z: torch.Tensor,
    plain: bool,
    b_data: torch.Tensor,
    demo_b: torch.Tensor,
    domain: str,
    task: str,
    seeds: list[int],
    horizon: int,
    demo: tuple[torch.Tensor, torch.Tensor | None],
    actions: int,
) -> dict:
    """One z: its rollout's return, r_z over rollout / demo / data, and F's value check."""
    w = implied_reward_weights(model, z, plain)  # r_z(s') = B(s')^T w
    episodes = rollout(domain, task, FBPolicy(model, z), seeds)
    obs = episodes.observation
    visited = torch.as_tensor(obs[:, 1:].reshape(-1, obs.shape[-1]), dtype=torch.float32)
    r_data = b_data @ w
    r_roll, r_demo = float((model.backward(visited) @ w).mean()), float((demo_b @ w).mean())
    std = float(r_data.std())
    return {
        "return_mean": float(np.mean(episodes.returns)),
        "r_z_rollout": r_roll,
        "r_z_demo": r_demo,
        "r_z_data_mean": float(r_data.mean()),
        "r_z_data_std": std,
        "r_z_data_p99": float(torch.quantile(r_data[:: max(1, len(r_data) // 200_000)], 0.99)),
        "gap": (r_roll - r_demo) / std,
        "value": value_check(model, z, w, obs, horizon),
        "at_demo": actor_check(model, z, demo[0], demo[1], actions),
        "at_rollout": actor_check(model, z, visited[::10], None, actions),
    }


@torch.no_grad()
def actor_check(
    model: FBModel, z: torch.Tensor, obs: torch.Tensor, demo_act: torch.Tensor | None, n: int
) -> dict:
    """max over random (and demo) actions of Q minus Q of the actor's action, per state."""
    gen = torch.Generator().manual_seed(0)
    rand = torch.rand(len(obs), n, model.config.act_dim, generator=gen) * 2 - 1
    mu = model.act(obs, z)
    local = (mu[:, None] + 0.2 * torch.randn(rand.shape, generator=gen)).clamp(-1, 1)
    cand = torch.cat([rand, local] + ([] if demo_act is None else [demo_act[:, None]]), 1)
    k = cand.shape[1]
    q = model.q_value(obs.repeat_interleave(k, 0), z, cand.reshape(-1, cand.shape[-1])).reshape(
        -1, k
    )
    q_pi = model.q_value(obs, z, mu)
    scale = q[:, :n].std(1).clamp_min(1e-6)
    best_global = torch.cat([q[:, :n], q[:, 2 * n :]], 1).max(1).values
    out = {
        "saturated": float((mu.abs() > 0.99).float().mean()),
        "actor_gap": float(((best_global - q_pi) / scale).mean()),
        "actor_gap_local": float(((q[:, n : 2 * n].max(1).values - q_pi) / scale).mean()),
    }
    if demo_act is not None:
        out["demo_adv"] = float(((q[:, -1] - q_pi) / scale).mean())
    return out


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
    p.add_argument("--plain", action="store_true", help="r_z = B^T z, without C^-1")
    p.add_argument("--actions", type=int, default=64, help="random actions of the actor check")
    args = p.parse_args()
    torch.set_num_threads(args.threads)
    model, data = FBModel.load(args.model), load_dataset(args.data)
    tasks = get_domain(data.domain).task_names if args.tasks == "all" else args.tasks.split(",")
    b = dataset_backward(model, data)
    seeds = [10_000 + i for i in range(args.episodes)]
    table: dict = {"model": args.model, "data": args.data, "demos": args.demos, "plain": args.plain}
    table["tasks"] = {}
    print(HEADER)
    for task in tasks:
        reward = torch.from_numpy(data.reward(task)).reshape(-1, 1).float()
        demos = Demos.load(Path(args.demos) / f"{task}.npz").select([0])
        batch = prepare(model, demos, gamma=model.gamma)
        zs = {"ERFB": erfb(model, batch)[0], "z_r": model.project_z((reward * b).mean(0))}
        row = {"demo_return": float(demos.trajectories[0].reward.sum())}
        for name, z in zs.items():
            r = probe_z(
                model,
                z,
                args.plain,
                b,
                batch.b_next,
                data.domain,
                task,
                seeds,
                args.horizon,
                (batch.obs, batch.action),
                args.actions,
            )
            row[name] = r
            print(row_text(name, task, r), flush=True)
        table["tasks"][task] = row
    if args.json:
        atomic_write_text(args.json, json.dumps(table, indent=1) + "\n")


if __name__ == "__main__":
    main()
