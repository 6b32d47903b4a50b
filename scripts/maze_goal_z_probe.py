"""Why one demonstration scores below the zero-shot z_r on the maze's reach tasks.

An expert demonstration of a reach task spends most of its steps at rest on the goal, so
ERFB's z = E_demo[B(s)] is close to B(goal at rest). This probe rolls out, per reach task:
  z_r            E_rho[r(s) B(s)] from the relabeled dataset (the zero-shot check)
  ERFB           E_demo[B(s)] from the task's committed demonstration (fbil's erfb)
  B(goal, rest)  B of the goal position with zero velocity
  B(goal, data v) B of the goal position averaged over velocities drawn from the dataset
and prints the mean return and the cosine of each z with z_r. It also prints which share of
the dataset's states are at rest and how many of those touch a wall: if resting states
exist only against walls, B(goal at rest) is an extrapolation that the velocity-averaged
goal avoids.

Usage: python scripts/maze_goal_z_probe.py MODEL --data DIR --demos DIR [--episodes N]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import torch

from fbil.data import load_dataset
from fbil.envs import get_task, maze, rollout
from fbil.fb.model import FBModel
from fbil.fb.policy import FBPolicy
from fbil.fb.zero_shot import dataset_backward
from fbil.imitation.core import prepare
from fbil.imitation.demos import Demos
from fbil.imitation.methods.reward import erfb

TASKS = ("reach_top_left", "reach_top_right", "reach_bottom_left", "reach_bottom_right")


def goal_zs(model: FBModel, goal: np.ndarray, velocities: np.ndarray) -> dict[str, torch.Tensor]:
    """z from B at the goal position: at rest, and averaged over the given velocities."""

    def at(v: np.ndarray) -> torch.Tensor:
        obs = np.concatenate([np.repeat(goal[None], len(v), 0), v], 1).astype(np.float32)
        return model.project_z(model.backward(obs).mean(0))

    return {"B(goal, rest)": at(np.zeros((1, 2), np.float32)), "B(goal, data v)": at(velocities)}


def resting_states(states: np.ndarray, speed: float = 1e-3, margin: float = 0.01) -> str:
    """Share of states at rest, and of those, the share within `margin` of a wall."""
    rest = states[np.linalg.norm(states[:, 2:], axis=1) < speed, :2]
    at_wall = 100 * float(maze.near_wall(rest, margin).mean())
    return (
        f"dataset states at rest (speed < {speed}): {100 * len(rest) / len(states):.1f} %, "
        f"of which {at_wall:.1f} % within {100 * margin:.0f} cm "
        "of a wall"
    )


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("model")
    p.add_argument("--data", required=True)
    p.add_argument("--demos", default="artifacts/demos/point_mass_maze")
    p.add_argument("--episodes", type=int, default=10)
    p.add_argument("--threads", type=int, default=1)
    args = p.parse_args()
    torch.set_num_threads(args.threads)
    model, data = FBModel.load(args.model), load_dataset(args.data)
    b = dataset_backward(model, data)
    nxt = data.observation[data.next_index]
    velocities = nxt[np.random.default_rng(0).integers(0, len(nxt), 256), 2:]
    seeds = [10_000 + i for i in range(args.episodes)]
    print(resting_states(nxt))
    names = ("z_r", "ERFB", "B(goal, rest)", "B(goal, data v)")
    print("task".ljust(20) + "".join(n.rjust(18) for n in names))
    for task in TASKS:
        r = torch.from_numpy(data.reward(task)).reshape(-1, 1)
        z_r = model.project_z((r * b).mean(0))
        demos = Demos.load(Path(args.demos) / f"{task}.npz").select([0])
        z_er, _ = erfb(model, prepare(model, demos, gamma=0.99))
        goal = np.asarray(get_task(data.domain, task).goal, np.float32)
        zs = {"z_r": z_r, "ERFB": z_er, **goal_zs(model, goal, velocities)}
        cells = []
        for name in names:
            z = zs[name]
            ret = float(np.mean(rollout(data.domain, task, FBPolicy(model, z), seeds).returns))
            cos = float(z @ z_r / (z.norm() * z_r.norm()))
            cells.append(f"{ret:7.1f} (cos {cos:4.2f})")
        print(task.ljust(20) + "".join(c.rjust(18) for c in cells))


if __name__ == "__main__":
    main()
