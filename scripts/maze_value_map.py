"""Where a maze FB model's values point: for each reach task, z_r from the relabeled dataset,
then V(s) = F(s, mu(s, z_r), z_r)^T z_r over a grid of positions at rest, with the actor's
push as arrows. A model whose zero-shot policies work shows values rising toward the goal
from the start room, through the doorways.

With --quantity reward it maps instead the reward the model actually optimises for z_r:
its projection on B's span, r_hat(s) = B(s)^T Cov^-1 z_r (Cov = E[B B^T] over the data),
and prints per task how far r_hat's peak lies from the goal and the radius of the area where
r_hat exceeds half its peak (the true reward's half-maximum radius is 6.4 cm). A peak off
the goal or wider than that bounds how precisely pi_{z_r} can stop on the goal, whatever F.

Usage: python scripts/maze_value_map.py MODEL --data DIR --out PNG [--grid N]
           [--quantity value|reward]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import torch

from fbil.data import load_dataset
from fbil.envs import get_task, maze
from fbil.envs.render import _pyplot, _save, draw_maze
from fbil.fb.model import FBModel
from fbil.fb.zero_shot import dataset_backward

TASKS = ("reach_top_left", "reach_top_right", "reach_bottom_left", "reach_bottom_right")


def rest_grid(n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Positions (n*n, 2), observations at rest (n*n, 4) and the wall mask (n*n,)."""
    g = np.linspace(-maze.JOINT_LIMIT, maze.JOINT_LIMIT, n, dtype=np.float32)
    xy = np.stack(np.meshgrid(g, g, indexing="xy"), -1).reshape(-1, 2)
    obs = np.concatenate([xy, np.zeros_like(xy)], 1)
    return xy, obs, maze.in_inner_wall(xy, maze.MASS_RADIUS, maze.MASS_RADIUS)


def value_grid(
    model: FBModel, z: torch.Tensor, n: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Positions (n*n, 2), V (n*n,) and actions (n*n, 2) at rest; NaN where walls are."""
    xy, obs, wall = rest_grid(n)
    with torch.no_grad():
        action = model.act(obs, z).numpy()
        value = (model.forward(obs, z) * model.project_z(z)).sum(-1).numpy()
    value[wall] = np.nan
    return xy, value, action


def implied_reward_grid(model: FBModel, w: torch.Tensor, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Positions (n*n, 2) and r_hat = B(s)^T w (n*n,) at rest; NaN where walls are."""
    xy, obs, wall = rest_grid(n)
    with torch.no_grad():
        r_hat = model.backward(obs).float() @ w
    r_hat = r_hat.numpy()
    r_hat[wall] = np.nan
    return xy, r_hat


def peak_report(task: str, xy: np.ndarray, r_hat: np.ndarray, n: int) -> str:
    """Distance of r_hat's peak from the goal and radius of its half-maximum area (cm)."""
    goal = np.asarray(get_task("point_mass_maze", task).goal)
    i = int(np.nanargmax(r_hat))
    cell = (2 * maze.JOINT_LIMIT / (n - 1)) ** 2
    area = float(np.sum(np.nan_to_num(r_hat, nan=-np.inf) > 0.5 * r_hat[i])) * cell
    off = 100 * float(np.linalg.norm(xy[i] - goal))
    radius = 100 * np.sqrt(area / np.pi)
    return f"{task}: peak {off:.1f} cm from the goal, half-max radius {radius:.1f} cm"


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("model")
    p.add_argument("--data", required=True, help="dataset to infer z_r from")
    p.add_argument("--out", required=True, help="PNG file")
    p.add_argument("--grid", type=int, default=25, help="positions per side")
    p.add_argument("--quantity", choices=("value", "reward"), default="value")
    args = p.parse_args()
    model, data = FBModel.load(args.model), load_dataset(args.data)
    b = dataset_backward(model, data).float()
    cov = b.T @ b / len(b) if args.quantity == "reward" else None
    plt = _pyplot()
    fig, axes = plt.subplots(1, 4, figsize=(16, 4.2), dpi=110)
    for ax, task in zip(axes, TASKS, strict=True):
        r = torch.from_numpy(data.reward(task)).reshape(-1, 1)
        z_raw = (r * b).mean(0)
        a = None  # the actor's push, drawn on value maps only
        if cov is not None:
            xy, v = implied_reward_grid(model, torch.linalg.solve(cov, z_raw), args.grid)
            print(peak_report(task, xy, v, args.grid))
        else:
            xy, v, a = value_grid(model, model.project_z(z_raw), args.grid)
        draw_maze(ax, task)
        n = args.grid
        im = ax.pcolormesh(
            xy[:n, 0], xy[::n, 1], v.reshape(n, n), cmap="viridis", shading="nearest", zorder=1
        )
        if a is not None:
            ax.quiver(xy[:, 0], xy[:, 1], a[:, 0], a[:, 1], color="white", scale=40, zorder=2)
        fig.colorbar(im, ax=ax, fraction=0.046)
        ax.set_title(task, fontsize=10)
        ax.set_aspect("equal")
        ax.set_xticks([])
        ax.set_yticks([])
    steps = model.metadata.get("steps", "?")
    name = Path(args.model).name
    title = {
        "value": "V(s) = F(s, mu(s, z_r), z_r)^T z_r at rest (arrows: mu's push)",
        "reward": "implied reward r_hat(s) = B(s)^T Cov^-1 z_r at rest",
    }[args.quantity]
    fig.suptitle(f"{title}; {name}, {steps} steps")
    fig.tight_layout()
    print(_save(fig, args.out))


if __name__ == "__main__":
    main()
