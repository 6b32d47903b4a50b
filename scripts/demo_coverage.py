"""Does the dataset hold the demonstrations' actions where it holds their states?

For each task's first committed demonstration, the distance from each demo state to its
nearest dataset state, and from each demo (state, action) pair to its nearest dataset pair,
next to the same distances between dataset points and their nearest other dataset point
(500 random probes). States and actions are scaled coordinate-wise by the dataset's standard
deviations. Also the share of action coordinates beyond 0.99 in absolute value, in the data
and in each demo. When the states are covered (demo-to-data close to data-to-data) but the pairs
are not, the data shows the demo's states only with other actions, and F must extrapolate
to value the demo's actions.

Usage: python scripts/demo_coverage.py --data DIR --demos DIR [--tasks all] [--json FILE]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import torch

from fbil.checkpoint import atomic_write_text
from fbil.data import load_dataset
from fbil.envs import get_domain
from fbil.imitation.demos import Demos


def nearest_distance(
    queries: torch.Tensor, points: torch.Tensor, chunk: int = 65_536
) -> torch.Tensor:
    """Distance from each query to its nearest point (brute force, in chunks)."""
    best = torch.full((len(queries),), float("inf"))
    for i in range(0, len(points), chunk):
        best = torch.minimum(best, torch.cdist(queries, points[i : i + chunk]).min(1).values)
    return best


def summary(d: torch.Tensor) -> dict:
    return {"median": float(d.median()), "p90": float(d.quantile(0.9))}


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--data", required=True)
    p.add_argument("--demos", required=True)
    p.add_argument("--tasks", default="all")
    p.add_argument("--threads", type=int, default=1)
    p.add_argument("--json", default=None)
    args = p.parse_args()
    torch.set_num_threads(args.threads)
    data = load_dataset(args.data)
    tasks = get_domain(data.domain).task_names if args.tasks == "all" else args.tasks.split(",")
    j = data.next_index  # transition j: state j - 1, action j (ExORL's layout)
    obs = torch.as_tensor(np.asarray(data.observation[j - 1], np.float32))
    act = torch.as_tensor(np.asarray(data.action[j], np.float32))
    s_scale, a_scale = obs.std(0).clamp_min(1e-6), act.std(0).clamp_min(1e-6)
    states, pairs = obs / s_scale, torch.cat([obs / s_scale, act / a_scale], 1)
    probe = torch.randperm(len(states), generator=torch.Generator().manual_seed(0))[:500]
    keep = torch.ones(len(states), dtype=torch.bool)
    keep[probe] = False
    table: dict = {
        "data": args.data,
        "demos": args.demos,
        "data_to_data": {
            "state": summary(nearest_distance(states[probe], states[keep])),
            "pair": summary(nearest_distance(pairs[probe], pairs[keep])),
            "saturated": float((act.abs() > 0.99).float().mean()),
        },
        "tasks": {},
    }
    base = table["data_to_data"]
    print(
        f"data to data: state {base['state']['median']:.2f}, pair {base['pair']['median']:.2f}; "
        f"action coordinates beyond 0.99: {base['saturated']:.2f}"
    )
    for task in tasks:
        traj = Demos.load(Path(args.demos) / f"{task}.npz").select([0]).trajectories[0]
        if traj.action is None:
            print(f"{task}: the demo has no actions; skipped")
            continue
        d_obs = torch.as_tensor(np.asarray(traj.observation[:-1], np.float32)) / s_scale
        raw_act = torch.as_tensor(np.asarray(traj.action, np.float32))
        row = {
            "state": summary(nearest_distance(d_obs, states)),
            "pair": summary(nearest_distance(torch.cat([d_obs, raw_act / a_scale], 1), pairs)),
            "saturated": float((raw_act.abs() > 0.99).float().mean()),
        }
        table["tasks"][task] = row
        print(
            f"{task:24} demo to data: state {row['state']['median']:.2f} "
            f"(p90 {row['state']['p90']:.2f}), pair {row['pair']['median']:.2f} "
            f"(p90 {row['pair']['p90']:.2f}); saturated {row['saturated']:.2f}",
            flush=True,
        )
    if args.json:
        atomic_write_text(args.json, json.dumps(table, indent=1) + "\n")


if __name__ == "__main__":
    main()
