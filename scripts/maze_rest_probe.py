"""Where the z's inferred from a reach demonstration send the maze policy, and why.

For each reach task and each z below, this prints (and writes with --json):
  return      mean return of pi_z over the episodes, from the standard start
  end         where pi_z spends its last 200 steps: distance to the goal (cm), mean speed
              (cm/s) and the share of those steps within 1 cm of a wall
  peak        the 1 000 dataset states with the highest implied reward
              r(s) = B(s)^T Cov^-1 z: their mean distance to the goal (cm), mean speed (cm/s)
              and share within 1 cm of a wall
  cos         the cosine of z with z_r
  contrast    the implied reward's mean over three sets of dataset states, in standard
              deviations of r over the dataset from its mean: near (within 3 cm of the goal),
              near & slow (also under 2 cm/s), and far rest (under 1 mm/s, at a wall, more
              than 10 cm from the goal)

z's: z_r = E_rho[r B] (zero-shot); ERFB = E_demo[B] (the task's first committed demo);
B(goal, rest) = B of the goal position with zero velocity; "near goal, slow" / "near goal,
fast" = mean B of the dataset's next states within 3 cm of the goal, in the slowest and the
fastest third of their speeds. If the demo-derived z's peak on resting states at walls
while the slow in-data goal states do not, resting in open space is what B has never seen.

Usage: python scripts/maze_rest_probe.py MODEL --data DIR [--demos DIR] [--episodes 5]
       [--json OUT]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import torch

from fbil.data import load_dataset
from fbil.envs import get_task, maze, rollout
from fbil.errors import FbilError
from fbil.fb.model import FBModel
from fbil.fb.policy import FBPolicy
from fbil.fb.zero_shot import dataset_backward
from fbil.imitation.core import prepare
from fbil.imitation.demos import Demos
from fbil.imitation.methods.reward import erfb

TASKS = ("reach_top_left", "reach_top_right", "reach_bottom_left", "reach_bottom_right")
NAMES = ("z_r", "ERFB", "B(goal, rest)", "near goal, slow", "near goal, fast")


def describe(pos: np.ndarray, vel: np.ndarray, goal: np.ndarray) -> dict[str, float]:
    """Mean distance to the goal and speed (cm, cm/s), and the share of states at a wall."""
    return {
        "dist_cm": round(100 * float(np.linalg.norm(pos - goal, axis=1).mean()), 1),
        "speed_cms": round(100 * float(np.linalg.norm(vel, axis=1).mean()), 2),
        "wall_share": round(float(maze.near_wall(pos, 0.01).mean()), 2),
    }


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("model")
    p.add_argument("--data", required=True)
    p.add_argument("--demos", default="artifacts/demos/point_mass_maze")
    p.add_argument("--episodes", type=int, default=5)
    p.add_argument("--threads", type=int, default=1)
    p.add_argument("--json", default=None, help="also write the table here")
    args = p.parse_args()
    torch.set_num_threads(args.threads)
    model, data = FBModel.load(args.model), load_dataset(args.data)
    if data.domain != "point_mass_maze":
        raise FbilError(f"this probe is for point_mass_maze data, got {data.domain}")
    with torch.no_grad():
        b = dataset_backward(model, data)
        implied = b @ torch.linalg.inv(model.cov_b.double()).float()  # rows: B(s)^T Cov^-1
    nxt = data.observation[data.next_index]
    pos, vel = nxt[:, :2], nxt[:, 2:]
    speed = np.linalg.norm(vel, axis=1)
    wall = maze.near_wall(pos, 0.01)
    seeds = [10_000 + i for i in range(args.episodes)]
    out: dict[str, dict[str, dict[str, object]]] = {}
    for task in TASKS:
        goal = np.asarray(get_task(data.domain, task).goal, np.float32)
        r = torch.from_numpy(data.reward(task)).reshape(-1, 1)
        dist = np.linalg.norm(pos - goal, axis=1)
        near = np.flatnonzero(dist < 0.03)
        sets = {
            "near": dist < 0.03,
            "near & slow": (dist < 0.03) & (speed < 0.02),
            "far rest": (speed < 0.001) & wall & (dist > 0.1),
        }
        lo, hi = np.quantile(speed[near], [1 / 3, 2 / 3])
        with torch.no_grad():
            z_r = model.project_z((r * b).mean(0))
            demos = Demos.load(Path(args.demos) / f"{task}.npz").select([0])
            zs = {
                "z_r": z_r,
                "ERFB": erfb(model, prepare(model, demos, gamma=model.gamma))[0],
                "B(goal, rest)": model.project_z(
                    model.backward(np.concatenate([goal, [0.0, 0.0]])[None].astype(np.float32))[0]
                ),
                "near goal, slow": model.project_z(b[near[speed[near] <= lo]].mean(0)),
                "near goal, fast": model.project_z(b[near[speed[near] >= hi]].mean(0)),
            }
        out[task] = {}
        print(
            f"{task} (goal {[round(float(g), 2) for g in goal]}; {len(near)} dataset states within "
            f"3 cm, {int(sets['near & slow'].sum())} of them under 2 cm/s; speed terciles "
            f"{100 * lo:.1f} / {100 * hi:.1f} cm/s)"
        )
        out[task]["counts"] = {k: int(m.sum()) for k, m in sets.items()}  # type: ignore[assignment]
        for name in NAMES:
            z = zs[name]
            eps = rollout(data.domain, task, FBPolicy(model, z), seeds)
            tail = eps.observation[:, -200:].reshape(-1, 4)
            rhat = (implied @ z).numpy()
            top = np.argsort(rhat)[-1000:]
            std = (rhat - rhat.mean()) / rhat.std()
            row = {
                "return": round(float(eps.returns.mean()), 1),
                "cos": round(float(z @ z_r / (z.norm() * z_r.norm())), 2),
                "end": describe(tail[:, :2], tail[:, 2:], goal),
                "peak": describe(pos[top], vel[top], goal),
                "contrast": {k: round(float(std[m].mean()), 2) for k, m in sets.items()},
            }
            out[task][name] = row
            e, k, c = row["end"], row["peak"], row["contrast"]
            print(
                f"  {name:16s} return {row['return']:6.1f}  cos {row['cos']:5.2f}  "
                f"end {e['dist_cm']:5.1f} cm {e['speed_cms']:5.2f} cm/s wall {e['wall_share']:.2f}"
                f"  peak {k['dist_cm']:5.1f} cm {k['speed_cms']:5.2f} cm/s"
                f" wall {k['wall_share']:.2f}"
                f"  contrast {c['near']:+.2f} / {c['near & slow']:+.2f} / {c['far rest']:+.2f}"
            )
    if args.json:
        Path(args.json).write_text(json.dumps(out, indent=1) + "\n")


if __name__ == "__main__":
    try:
        main()
    except FbilError as e:
        raise SystemExit(f"error: {e}") from None
