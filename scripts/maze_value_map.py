"""Where a maze FB model's values point: for each reach task, z_r from the relabeled dataset,
then V(s) = F(s, mu(s, z_r), z_r)^T z_r over a grid of positions at rest, with the actor's
push as arrows. A model whose zero-shot policies work shows values rising toward the goal
from the start room, through the doorways.

Usage: python scripts/maze_value_map.py MODEL --data DIR --out PNG [--grid N]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import torch

from fbil.data import load_dataset
from fbil.envs import maze
from fbil.envs.render import _pyplot, _save, draw_maze
from fbil.fb.model import FBModel
from fbil.fb.zero_shot import dataset_backward

TASKS = ("reach_top_left", "reach_top_right", "reach_bottom_left", "reach_bottom_right")


def value_grid(
    model: FBModel, z: torch.Tensor, n: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Positions (n*n, 2), V (n*n,) and actions (n*n, 2) at rest; NaN where walls are."""
    g = np.linspace(-maze.JOINT_LIMIT, maze.JOINT_LIMIT, n, dtype=np.float32)
    xy = np.stack(np.meshgrid(g, g, indexing="xy"), -1).reshape(-1, 2)
    obs = np.concatenate([xy, np.zeros_like(xy)], 1)
    with torch.no_grad():
        action = model.act(obs, z).numpy()
        value = (model.forward(obs, z) * model.project_z(z)).sum(-1).numpy()
    value[maze.in_inner_wall(xy, maze.MASS_RADIUS, maze.MASS_RADIUS)] = np.nan
    return xy, value, action


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("model")
    p.add_argument("--data", required=True, help="dataset to infer z_r from")
    p.add_argument("--out", required=True, help="PNG file")
    p.add_argument("--grid", type=int, default=25, help="positions per side")
    args = p.parse_args()
    model, data = FBModel.load(args.model), load_dataset(args.data)
    b = dataset_backward(model, data)
    plt = _pyplot()
    fig, axes = plt.subplots(1, 4, figsize=(16, 4.2), dpi=110)
    for ax, task in zip(axes, TASKS, strict=True):
        r = torch.from_numpy(data.reward(task)).reshape(-1, 1)
        z = model.project_z((r * b).mean(0))
        xy, v, a = value_grid(model, z, args.grid)
        draw_maze(ax, task)
        n = args.grid
        im = ax.pcolormesh(
            xy[:n, 0], xy[::n, 1], v.reshape(n, n), cmap="viridis", shading="nearest", zorder=1
        )
        ax.quiver(xy[:, 0], xy[:, 1], a[:, 0], a[:, 1], color="white", scale=40, zorder=2)
        fig.colorbar(im, ax=ax, fraction=0.046)
        ax.set_title(task, fontsize=10)
        ax.set_aspect("equal")
        ax.set_xticks([])
        ax.set_yticks([])
    steps = model.metadata.get("steps", "?")
    name = Path(args.model).name
    title = "V(s) = F(s, mu(s, z_r), z_r)^T z_r at rest (arrows: mu's push)"
    fig.suptitle(f"{title}; {name}, {steps} steps")
    fig.tight_layout()
    print(_save(fig, args.out))


if __name__ == "__main__":
    main()
