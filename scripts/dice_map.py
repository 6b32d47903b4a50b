"""Where a DICE baseline puts its weight on the maze: trains one method on one task (demo draw
0, the `cpu` budget, `--set` changes to its dual as in dice_diagnosis.py), then maps over
the floor, binned by the transitions' next positions on a sample of dataset rows:

  1. the discriminator's reward r (mean per cell),
  2. the share of the total weight w = d / d_D that each cell holds (log10; the weighted BC
     clones the actions of these rows),
  3. nu at rest and the policy's action at rest (arrows), with a 1 000-step rollout of the
     policy from the evaluation's first start (white) and the demo (red).

A working DICE puts its weight along the demo and its arrows along the path; the picture
says which of the three (reward, weights, policy) departs first.

Usage: python scripts/dice_map.py {demodice,smodice,lobsdice} TASK --out PNG [--set K=V]
       [--rows 200000] [--grid 30] [--penalty W] [--disc-steps N]
"""

from __future__ import annotations

import argparse

import numpy as np
import torch
from dice_diagnosis import add_setup_args, setup  # scripts/ is on sys.path when run

from fbil.baselines.common import dataset_rows
from fbil.baselines.dice import DiceLearner, advantage, train_dice
from fbil.envs import maze
from fbil.envs.render import _pyplot, _save, draw_maze
from fbil.envs.rollout import rollout


def cell_means(xy: np.ndarray, value: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Per-cell sum of `value` and count over an n x n grid of the floor."""
    edges = np.linspace(-maze.JOINT_LIMIT, maze.JOINT_LIMIT, n + 1)
    total = np.histogram2d(xy[:, 0], xy[:, 1], [edges, edges], weights=value)[0]
    count = np.histogram2d(xy[:, 0], xy[:, 1], [edges, edges])[0]
    return total.T, count.T


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_setup_args(p)
    p.add_argument("--out", required=True)
    p.add_argument("--rows", type=int, default=200_000)
    p.add_argument("--grid", type=int, default=30)
    args = p.parse_args()
    su = setup(args)
    data, demos, penalty, changes = su.data, su.demos, su.penalty, su.changes
    dual = su.cfg.dual
    kept: list[DiceLearner] = []

    def keep(step: int, learner: DiceLearner, metrics: dict[str, float]) -> None:
        if step == dual.steps:
            kept.append(learner)

    policy = train_dice(
        args.method, su.kind, demos, data, su.cfg, penalty, 0, su.union, keep, su.reward_fn
    )
    learner = kept[0]
    gen = torch.Generator().manual_seed(0)
    rows = torch.randint(0, int(data.num_transitions), (args.rows,), generator=gen)
    batch = dataset_rows(data, rows)
    with torch.no_grad():
        r = learner.reward(batch)
        e = advantage(learner.nu, batch, r, learner.gamma) / (1 + dual.alpha)
    w = torch.exp(e - e.max()) if dual.divergence == "kl" else torch.relu(e + 1)
    xy = batch.next_obs[:, :2].numpy()
    n = args.grid
    r_sum, count = cell_means(xy, r.numpy(), n)
    w_sum, _ = cell_means(xy, w.numpy(), n)
    g = np.linspace(-maze.JOINT_LIMIT, maze.JOINT_LIMIT, n)
    rest = np.stack(np.meshgrid(g, g, indexing="xy"), -1).reshape(-1, 2).astype(np.float32)
    rest_obs = np.concatenate([rest, np.zeros_like(rest)], 1)
    with torch.no_grad():
        nu_rest = learner.nu(torch.from_numpy(rest_obs)).squeeze(-1).numpy()
    act = policy.act(rest_obs)
    run = rollout("point_mass_maze", args.task, policy, [0]).observation[0]
    demo = np.asarray(demos.trajectories[0].observation)
    plt = _pyplot()
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.6), dpi=110)
    with np.errstate(invalid="ignore", divide="ignore"):
        panels = [
            (r_sum / count, "discriminator reward r (mean per cell)"),
            (np.log10(w_sum / w_sum.sum()), "log10 share of the weight w per cell"),
            (nu_rest.reshape(n, n), "nu at rest; arrows: the policy at rest"),
        ]
    for i, (ax, (grid, title)) in enumerate(zip(axes, panels, strict=True)):
        draw_maze(ax, args.task)
        im = ax.pcolormesh(g, g, grid, cmap="viridis", shading="nearest", zorder=1)
        fig.colorbar(im, ax=ax, fraction=0.046)
        ax.plot(demo[:, 0], demo[:, 1], color="red", lw=1, zorder=3)
        if i == 2:
            ax.quiver(rest[:, 0], rest[:, 1], act[:, 0], act[:, 1], color="white", zorder=2)
            ax.plot(run[:, 0], run[:, 1], color="white", lw=1.2, zorder=3)
        ax.set_title(title, fontsize=9)
        ax.set_aspect("equal")
        ax.set_xticks([])
        ax.set_yticks([])
    extra = f", {changes}" if changes else ""
    fig.suptitle(f"{args.method} on {args.task} (draw 0, penalty {penalty}{extra})")
    fig.tight_layout()
    print(_save(fig, args.out))


if __name__ == "__main__":
    main()
