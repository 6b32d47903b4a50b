"""How far the z-optimising FB-IL methods move from their warm start (imitation only, no
rollout).

For each MODEL (e.g. the snapshots of one run), each task's demo file in --demos and each
demo draw (K demos per draw, the grid's `demo_draw`), the ERFB z (every gradient method's
warm start) and each gradient method's z with the default optimiser, then
cos(z_method, z_erfb). A method whose z leaves its warm start farther as F trains on is
following F's values away from the z's F was trained on.

With --actor-check, also the implied-reward probe's actor gap at every 10th demo state for
every z, ERFB's included (`fbil.evaluation.implied.actor_check`: the best of 64 random, 64
local and the demo's action under F, minus the actor's, in units of Q's spread): whether
the actor still takes F's best actions for the z's the optimisers reach.

Usage: python scripts/z_drift.py MODEL [MODEL ...] --demos DIR [--tasks all]
           [--methods bcfb,fmfb,dmfb,bbellfb,fblossfb] [--draws 5] [--k 1] [--actor-check]
           [--json OUT]
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
from pathlib import Path
from typing import Any

import torch

from fbil.checkpoint import atomic_write_text
from fbil.errors import FbilError
from fbil.evaluation.benchmark import load_task_demos
from fbil.evaluation.evaluate import demo_draw
from fbil.evaluation.implied import actor_check
from fbil.fb.model import FBModel
from fbil.imitation import METHODS, Demos, imitate

GRADIENT = ("bcfb", "fmfb", "dmfb", "bbellfb", "fblossfb")


def cosines(
    model: FBModel, demos: Demos, methods: list[str], draws: int, k: int, actor: bool = False
) -> dict[str, list[float]]:
    """cos(z_method, z_erfb) per method, one value per draw; with `actor`, also each z's
    actor gap at the draw's demo states (keys "<method>_actor_gap", "erfb_actor_gap")."""
    out: dict[str, list[float]] = {m: [] for m in methods}
    for draw in range(draws):
        group = demo_draw(demos, k, draw)
        z0 = imitate(model, group, "erfb").z.flatten()
        zs = {m: imitate(model, group, m).z.flatten() for m in methods}
        for m, z in zs.items():
            out[m].append(float(torch.nn.functional.cosine_similarity(z, z0, dim=0)))
        if actor:
            obs, act = _demo_rows(group)
            for m, z in {"erfb": z0, **zs}.items():
                gap = actor_check(model, z, obs, act, 64)
                out.setdefault(f"{m}_actor_gap", []).append(gap["actor_gap"])
    return out


def _demo_rows(group: Demos, every: int = 10) -> tuple[torch.Tensor, torch.Tensor | None]:
    """Every `every`-th demo state s_t (t < T) and its action, when the file has them."""
    trajs = group.trajectories
    obs = torch.cat([torch.as_tensor(t.observation[:-1:every]).float() for t in trajs])
    if not group.has_actions:
        return obs, None
    act = torch.cat([torch.as_tensor(t.action[::every]).float() for t in trajs])
    return obs, act


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("models", nargs="+")
    p.add_argument("--demos", required=True, help="folder of <task>.npz demo files")
    p.add_argument("--tasks", default="all", help="comma list of tasks (all: every file)")
    p.add_argument("--methods", default=",".join(GRADIENT))
    p.add_argument("--draws", type=int, default=5)
    p.add_argument("--k", type=int, default=1)
    p.add_argument("--actor-check", action="store_true", help="also each z's actor gap")
    p.add_argument("--json", default=None)
    args = p.parse_args(argv)
    torch.set_num_threads(1)
    try:
        methods = [m.strip() for m in args.methods.split(",") if m.strip()]
        bad = [m for m in methods if m not in METHODS or not METHODS[m].gradient]
        if bad:
            raise FbilError(f"not gradient FB-IL methods: {', '.join(bad)}; use {GRADIENT}")
        demos = load_task_demos(args.demos, args.tasks, FBModel.load(args.models[0]).domain)
        rows: list[dict[str, Any]] = []
        for name in args.models:
            model = FBModel.load(name)
            per_task = {
                t: cosines(model, d, methods, args.draws, args.k, args.actor_check)
                for t, d in demos.items()
            }
            keys = list(next(iter(per_task.values())))
            mean = {m: statistics.mean(c for t in per_task for c in per_task[t][m]) for m in keys}
            rows.append({"model": name, "mean": mean, "tasks": per_task})
            print(f"{name}: " + ", ".join(f"{m} {v:.3f}" for m, v in mean.items()), flush=True)
    except FbilError as exc:
        print(f"z_drift: error: {exc}", file=sys.stderr)
        return 2
    if args.json:
        out = {"demos": args.demos, "k": args.k, "draws": args.draws, "rows": rows}
        atomic_write_text(Path(args.json), json.dumps(out, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
