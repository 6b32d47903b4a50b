"""GOAL-TD3's imitation score at several look-aheads k, on one goal model, without training.

GOAL-TD3 plays pi(s_t, g_t) with g_t the demonstration's state k steps ahead of step t;
`fbil benchmark` uses k = 10 (GOALFB's value in the paper). The goal radius epsilon the
model was trained with decides which k its reward taught it to reach: a radius about as
wide as the spread of the data's states pays for nearly any goal, a small one only for
goals a few steps away. This script scores the same demo draws, evaluation seeds and
episodes as a benchmark job at each k, all in one batched rollout per (task, draw), so the
k = 10 column repeats the benchmark's goal_td3 line (a check of the script).

Usage: python scripts/goal_lookahead_sweep.py --goal-model DIR --demos DIR
           [--tasks all] [--lookaheads 1,3,10] [--draws 2] [--episodes 20] [--seed 0]
           [--json FILE]
"""

from __future__ import annotations

import argparse
import json
import sys

import numpy as np

from fbil.baselines.goal_model import GoalModel
from fbil.baselines.goal_td3 import GoalTrackingPolicy
from fbil.checkpoint import atomic_write_text
from fbil.envs import get_domain
from fbil.errors import FbilError
from fbil.evaluation.evaluate import demo_draw, expert_return, rollout_policies
from fbil.imitation.demos import Demos


def sweep(
    model: GoalModel,
    demos: Demos,
    task: str,
    lookaheads: list[int],
    draws: int,
    episodes: int,
    seed: int,
) -> dict[str, list[float]]:
    """Per k, the score of each draw (return mean over episodes / the expert's return)."""
    expert = expert_return(demos)
    scores: dict[str, list[float]] = {str(k): [] for k in lookaheads}
    for draw in range(draws):
        goals = demo_draw(demos, 1, draw).trajectories[0].observation
        policies = [GoalTrackingPolicy(model, goals, k) for k in lookaheads]
        ep = rollout_policies(policies, model.config.domain, task, episodes, seed)
        for i, k in enumerate(lookaheads):
            returns = ep.returns[i * episodes : (i + 1) * episodes]
            scores[str(k)].append(float(np.mean(returns) / expert))
    return scores


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--goal-model", required=True, help="GOAL-TD3 model folder")
    p.add_argument("--demos", required=True, help="folder of TASK.npz demos")
    p.add_argument("--tasks", default="all")
    p.add_argument("--lookaheads", default="1,3,10", help="comma-separated k values")
    p.add_argument("--draws", type=int, default=2, help="K = 1 demo draws, as the benchmark")
    p.add_argument("--episodes", type=int, default=20)
    p.add_argument("--seed", type=int, default=0, help="the benchmark's --seed")
    p.add_argument("--json", default=None)
    args = p.parse_args(argv)
    try:
        lookaheads = [int(k) for k in args.lookaheads.split(",")]
        if not lookaheads or min(lookaheads) < 1:
            raise ValueError
    except ValueError:
        print(
            f"error: --lookaheads must be integers >= 1, got {args.lookaheads!r}", file=sys.stderr
        )
        return 2
    try:
        model = GoalModel.load(args.goal_model)
        domain = model.config.domain
        spec = get_domain(domain)
        tasks = spec.task_names if args.tasks == "all" else args.tasks.split(",")
        table: dict[str, object] = {"goal_model": args.goal_model, "domain": domain}
        per_task = {}
        for task in tasks:
            demos = Demos.load(f"{args.demos}/{task}.npz").validate(spec.obs_dim)
            per_task[task] = sweep(
                model, demos, task, lookaheads, args.draws, args.episodes, args.seed
            )
            shown = "  ".join(f"k={k}: {100 * np.mean(s):5.1f}" for k, s in per_task[task].items())
            print(f"{task:16s} {shown}", flush=True)
    except FbilError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    means = {
        str(k): [float(np.mean([per_task[t][str(k)][d] for t in tasks])) for d in range(args.draws)]
        for k in lookaheads
    }
    for k, m in means.items():
        print(
            f"k={k}: mean {100 * np.mean(m):.1f} %, draws " + ", ".join(f"{100 * x:.1f}" for x in m)
        )
    table.update(
        {
            "epsilon": model.config.epsilon,
            "lookaheads": lookaheads,
            "draws": args.draws,
            "episodes": args.episodes,
            "seed": args.seed,
            "tasks": per_task,
            "mean_by_draw": means,
            "command": " ".join(["python", *sys.argv]),
        }
    )
    if args.json:
        atomic_write_text(args.json, json.dumps(table, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
