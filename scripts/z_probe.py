"""Where the task-to-z map goes wrong: for each task, roll out the model's policy for
several ways of inferring z, and print each z's return and its cosine with z_r.

  z_r        E_rho[r(s') B(s')] over the relabeled dataset (`fbil zero-shot`)
  z_r>=0.5   E_rho[1{r(s') >= 0.5} B(s')]: the dataset's well-paid states only
  z_r-mean   E_rho[(r(s') - mean r) B(s')]: the reward without its mean (the same optimal
             policy for the exact model; z no longer leans on E[B])
  ERFB       E_demo[B(s')] from the task's first committed demonstration (fbil's erfb)
  demo r     E_demo[r(s') B(s')]: the demo's states weighted by their true reward
  ERFB-c     E_demo[B(s')] - E_rho[B(s')]: ERFB's reward rho_e/rho minus its mean 1 (the
             same optimal policy for the exact model)
  ERFB-nn    ERFB with each demo state replaced by its nearest dataset state (Euclidean
             distance after scaling each observation coordinate by the dataset's std)

Each cell also gives corr, the correlation over the dataset between the z's implied reward
B(s')^T z and the task's true reward (z_r's is the best a linear reward in B can do).

If ERFB-nn does much better than ERFB, B extrapolates badly at the demo's own states
(they lie off the data), and the demo-to-z map, not the policies, is what fails. The
probe also prints how far the demo's states lie from the data, next to how far dataset
states lie from their nearest other dataset state.

If the demo-based z's do well where z_r fails, the model's policies can do the task and
the dataset's reward-weighted average of B is what misleads z_r; the reverse points at
the demonstration's features. Any domain; the demos folder holds <task>.npz files.

Usage: python scripts/z_probe.py MODEL --data DIR --demos DIR [--tasks all] [--episodes 10]
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import torch
from probe_cli import load, probe_parser

from fbil.envs import rollout
from fbil.fb.model import FBModel
from fbil.fb.policy import FBPolicy
from fbil.fb.zero_shot import dataset_backward
from fbil.imitation.core import prepare
from fbil.imitation.demos import Demos
from fbil.imitation.methods.reward import erfb

NAMES = ("z_r", "z_r>=0.5", "z_r-mean", "ERFB", "demo r", "ERFB-c", "ERFB-nn")


def nearest(queries: torch.Tensor, points: torch.Tensor, chunk: int = 65_536) -> tuple:
    """Index of and distance to each query's nearest point (brute force, in chunks)."""
    best = torch.full((len(queries),), float("inf"))
    idx = torch.zeros(len(queries), dtype=torch.long)
    for i in range(0, len(points), chunk):
        d = torch.cdist(queries, points[i : i + chunk])
        m, j = d.min(1)
        better = m < best
        best = torch.where(better, m, best)
        idx = torch.where(better, j + i, idx)
    return idx, best


def task_zs(
    model: FBModel, b: torch.Tensor, reward: torch.Tensor, demos: Demos, nn_b: torch.Tensor
) -> dict:
    """The z's of the module's doc for one task; nn_b: B of each demo state's neighbour."""
    well_paid = (reward >= 0.5).float()
    batch = prepare(model, demos, gamma=model.gamma)
    z_er, _ = erfb(model, batch)
    demo_r = torch.cat([torch.as_tensor(t.reward, dtype=torch.float32) for t in demos.trajectories])
    return {
        "z_r": model.project_z((reward * b).mean(0)),
        "z_r>=0.5": model.project_z((well_paid * b).mean(0)),
        "z_r-mean": model.project_z(((reward - reward.mean()) * b).mean(0)),
        "ERFB": z_er,
        "demo r": model.project_z((batch.weight * demo_r) @ batch.b_next),
        "ERFB-c": model.project_z(batch.weight @ batch.b_next - b.mean(0)),
        "ERFB-nn": model.project_z(batch.weight @ nn_b),
    }


def main() -> None:
    args = probe_parser(__doc__.splitlines()[0]).parse_args()
    model, data, tasks = load(args)
    b = dataset_backward(model, data)
    nxt = torch.as_tensor(np.asarray(data.observation[data.next_index], np.float32))
    scale = nxt.std(0).clamp_min(1e-6)
    points = nxt / scale
    probe = torch.randperm(len(points), generator=torch.Generator().manual_seed(0))[:500]
    rest = torch.ones(len(points), dtype=torch.bool)
    rest[probe] = False
    _, d_self = nearest(points[probe], points[rest])
    seeds = [10_000 + i for i in range(args.episodes)]
    print("return (cosine to z_r, correlation of B^T z with the reward over the data)")
    print("task".ljust(10) + "".join(n.rjust(20) for n in NAMES))
    table: dict = {"model": args.model, "data": args.data, "demos": args.demos, "tasks": {}}
    table["data_nn_distance"] = {
        "median": float(d_self.median()),
        "p90": float(d_self.quantile(0.9)),
    }
    for task in tasks:
        reward = torch.from_numpy(data.reward(task)).reshape(-1, 1)
        demos = Demos.load(Path(args.demos) / f"{task}.npz").select([0])
        demo_next = torch.as_tensor(np.asarray(demos.trajectories[0].observation[1:], np.float32))
        idx, dist = nearest(demo_next / scale, points)
        zs = task_zs(model, b, reward, demos, b[idx])
        cells, row = [], {}
        for name in NAMES:
            z = zs[name]
            ret = float(np.mean(rollout(data.domain, task, FBPolicy(model, z), seeds).returns))
            cos = float(z @ zs["z_r"] / (z.norm() * zs["z_r"].norm()))
            corr = float(np.corrcoef((b @ z).numpy(), reward[:, 0].numpy())[0, 1])
            cells.append(f"{ret:7.1f} ({cos:5.2f} {corr:5.2f})")
            row[name] = {"return_mean": ret, "cos_z_r": cos, "corr_reward": corr}
        print(task.ljust(10) + "".join(c.rjust(20) for c in cells), flush=True)
        print(
            f"{'':10}demo-to-data distance median {dist.median():.2f} "
            f"(p90 {dist.quantile(0.9):.2f}); data-to-data median {d_self.median():.2f} "
            f"(p90 {d_self.quantile(0.9):.2f})",
            flush=True,
        )
        row["demo_nn_distance"] = {"median": float(dist.median()), "p90": float(dist.quantile(0.9))}
        table["tasks"][task] = row
    if args.json:
        Path(args.json).write_text(json.dumps(table, indent=1) + "\n")


if __name__ == "__main__":
    main()
