"""Can a GOAL-TD3 model reach a demo's last state when asked to go straight there?

For each task: the goal is the final state of the task's first demonstration in draw
`--draw`, held fixed for the whole episode (a one-state "demo" to GoalTrackingPolicy),
from the task's standard starts. Per task it prints the task's mean return, the share of
episodes that come within the model's own goal radius (its `distance` metric, ε) at any
step, the mean distance at the end, and min(Q1, Q2) at the first state. Seconds per model:
a verdict on a retrained goal model before its 40-job grid (docs/baselines.md, "Session
33"). Any domain whose goal model and demos exist.

Usage: python scripts/goal_reach_check.py MODEL --demos DIR [--tasks T1,T2] [--draw 1]
           [--episodes 10] [--json]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

import numpy as np

from fbil.baselines.goal_model import GoalModel
from fbil.baselines.goal_td3 import GoalTrackingPolicy
from fbil.errors import FbilError
from fbil.evaluation.evaluate import demo_draw, rollout_policies
from fbil.imitation.demos import Demos

REACH = "reach_top_left,reach_top_right,reach_bottom_left,reach_bottom_right"


def check(model: GoalModel, demos: Path, task: str, draw: int, episodes: int) -> dict[str, Any]:
    states = demo_draw(Demos.load(demos / f"{task}.npz"), 1, draw).trajectories[0].observation
    goal = states[-1:]
    ep = rollout_policies([GoalTrackingPolicy(model, goal, 0)], model.domain, task, episodes, 0)
    d = model.config.obs_dim
    scale = model.agent.obs_stats[1, :d].numpy() if model.config.distance == "standardized" else 1
    dist = np.linalg.norm((ep.observation - goal) / scale, axis=-1)  # (E, T+1)
    first = ep.observation[:, 0]
    q0 = model.q(first, goal, model.act(first, goal))
    return {
        "return_mean": float(ep.returns.mean()),
        "reached_share": float((dist.min(axis=1) <= model.config.epsilon).mean()),
        "end_distance_mean": float(dist[:, -1].mean()),
        "epsilon": model.config.epsilon,
        "q_start_mean": float(q0.mean()),
    }


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("model")
    p.add_argument("--demos", required=True, help="folder of <task>.npz demo files")
    p.add_argument("--tasks", default=REACH, help="a comma list (default: the maze's reach)")
    p.add_argument("--draw", type=int, default=1)
    p.add_argument("--episodes", type=int, default=10)
    p.add_argument("--json", action="store_true")
    args = p.parse_args(argv)
    try:
        model = GoalModel.load(args.model)
        out = {
            t: check(model, Path(args.demos), t, args.draw, args.episodes)
            for t in args.tasks.split(",")
        }
    except FbilError as exc:
        print(f"goal_reach_check: error: {exc}", file=sys.stderr)
        return 2
    if args.json:
        print(json.dumps({"model": args.model, "draw": args.draw, "tasks": out}))
        return 0
    for task, r in out.items():
        print(
            f"{task:<24} return {r['return_mean']:7.1f}  reached {r['reached_share']:.0%}  "
            f"end distance {r['end_distance_mean']:.3f} (ε {r['epsilon']:.3f})  "
            f"Q at start {r['q_start_mean']:.1f}"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
