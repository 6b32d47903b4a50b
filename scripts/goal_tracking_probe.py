"""Where does goal tracking lose the demonstration: on the way to the expert's behaviour, or
while following it? GOAL-TD3 and GOALFB both play pi(s, g_t) with g_t the demo's state
LOOKAHEAD steps ahead; this probe starts each one *inside* the demonstration, at its own
physics state at step t0, and tracks the rest of it.

For each task and each of the first N demonstrations, for each t0 in --starts, both
methods track the demo from its state at t0 for the remaining steps. Printed per (task,
method, t0): the return over those steps as a share of the demo's own return over them,
and the mean distance between the rollout's state at step t and the demo's state at t0 + t
in the goal model's standardised metric (GOAL-TD3's goal radius epsilon is in the same
units; `within` is the share of steps inside it).

- t0 = 0 is the demo's own start (the standard start distribution, one state of it).
- If a method tracks well from t0 = 500 (inside the expert's steady behaviour) but poorly
  from 0, it fails on the way there (getting up, speeding up); if it fails from 500 too,
  it cannot follow the expert's behaviour at all with this model.

With --data, also the same question where HER trained the goal policy (`reach`): from
dataset states toward dataset states LOOKAHEAD steps later. A goal policy that fails there
did not learn goal reaching; one that succeeds there but not on the demo fails to carry it
to the expert's states.

Usage: python scripts/goal_tracking_probe.py --model FB_DIR --goal-model GOAL_DIR
           --demos DIR [--tasks all] [--demos-used 5] [--starts 0,100,500]
           [--data DIR --pairs 300] [--json FILE]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

import numpy as np
import torch

from fbil.baselines.goal_model import GoalModel
from fbil.baselines.goal_td3 import LOOKAHEAD, GoalTrackingPolicy
from fbil.checkpoint import atomic_write_text
from fbil.data import load_dataset
from fbil.envs import get_domain
from fbil.envs.rollout import BatchedEnv
from fbil.errors import FbilError
from fbil.evaluation.evaluate import MultiPolicy
from fbil.fb.model import FBModel
from fbil.imitation.api import imitate
from fbil.imitation.demos import Demos

METHODS = ("goal_td3", "goalfb")


def track(
    fb: FBModel, goal: GoalModel, demos: Demos, task: str, t0: int
) -> dict[str, dict[str, float]]:
    """Both methods from each demo's state at t0, over the demo's remaining steps."""
    trajs = demos.trajectories
    if any(t.physics is None or t.reward is None for t in trajs):
        raise FbilError(f"{task}: the demos need physics states and rewards (`fbil demos`)")
    steps = len(trajs[0]) - t0
    if steps < 1:
        raise FbilError(f"--starts: {t0} is past the demos' {len(trajs[0])} steps")
    policies: list[Any] = [GoalTrackingPolicy(goal, t.observation) for t in trajs]
    policies += [imitate(fb, Demos([t], dict(demos.metadata)), "goalfb") for t in trajs]
    physics = [np.asarray(t.physics) for t in trajs]
    starts = np.stack([ph[t0] for ph in physics] * len(METHODS))
    env = BatchedEnv(goal.domain, task, len(starts))
    multi = MultiPolicy(policies, 1)  # row i plays policy i, on the demo's own clock
    eps = env.rollout(
        lambda obs, step: multi(obs, t0 + step), [0] * len(starts), steps, start_states=starts
    )
    scale = goal.agent.obs_stats[1, : goal.config.obs_dim].numpy()
    demo_obs = np.stack([t.observation[t0:] for t in trajs])
    demo_return = np.array([np.asarray(t.reward)[t0:].sum() for t in trajs])
    out = {}
    for i, method in enumerate(METHODS):
        block = slice(i * len(trajs), (i + 1) * len(trajs))
        dist = np.linalg.norm((eps.observation[block] - demo_obs) / scale, axis=-1)
        out[method] = {
            "return_share": float(np.mean(eps.returns[block] / demo_return)),
            "distance": float(dist.mean()),
            "within": float((dist <= goal.config.epsilon).mean()),
        }
    return out


def reach(
    fb: FBModel, goal: GoalModel, data: Any, task: str, n: int, horizon: int
) -> dict[str, dict[str, float]]:
    """In the data, where HER trained the goal policy: from n dataset states, each method
    (and zero actions, the floor) heads for the state `horizon` steps later in the same
    episode, for 2 x horizon steps; the share that comes within epsilon of it, and the
    mean of the closest distance reached (standardised)."""
    rng = np.random.default_rng(0)
    rows = data.next_index[data.next_index + horizon <= data.state_episode_end[data.next_index]]
    rows = np.sort(rng.choice(rows, n, replace=False))
    goals = np.asarray(data.observation[rows + horizon], np.float32)
    physics = data.physics()[rows]
    z = fb.goal_inference(goals)
    acts = {
        "goal_td3": lambda o: goal.act(o, goals),
        "goalfb": lambda o: fb.act(o, z).numpy(),
        "zero_action": lambda o: np.zeros((len(o), goal.config.act_dim), np.float32),
    }
    names = list(acts)

    def policy(obs: np.ndarray, step: int) -> np.ndarray:
        return np.concatenate(
            [acts[m](o) for m, o in zip(names, np.split(obs, len(names)), strict=True)]
        )

    env = BatchedEnv(goal.domain, task, n * len(names))
    eps = env.rollout(policy, [0] * n * len(names), 2 * horizon, np.tile(physics, (len(names), 1)))
    scale = goal.agent.obs_stats[1, : goal.config.obs_dim].numpy()
    out = {}
    for i, m in enumerate(names):
        traj = eps.observation[i * n : (i + 1) * n]
        closest = np.linalg.norm((traj - goals[:, None]) / scale, axis=-1)[:, 1:].min(1)
        out[m] = {
            "reached": float((closest <= goal.config.epsilon).mean()),
            "closest": float(closest.mean()),
        }
    return out


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--model", required=True, help="FB model folder (GOALFB)")
    p.add_argument("--goal-model", required=True, help="GOAL-TD3 model folder")
    p.add_argument("--demos", required=True, help="folder of TASK.npz demos")
    p.add_argument("--tasks", default="all")
    p.add_argument("--demos-used", type=int, default=5, help="the first N of each task")
    p.add_argument("--starts", default="0,100,500", help="t0 values, demo steps")
    p.add_argument("--data", default=None, help="also the in-data check (see `reach`)")
    p.add_argument("--pairs", type=int, default=300, help="--data: start-goal pairs")
    p.add_argument("--json", default=None)
    args = p.parse_args(argv)
    torch.set_num_threads(1)
    try:
        fb, goal = FBModel.load(args.model), GoalModel.load(args.goal_model)
        names = get_domain(goal.domain).task_names if args.tasks == "all" else args.tasks.split(",")
        starts = [int(s) for s in args.starts.split(",")]
        table: dict[str, Any] = {"command": " ".join(["python", *sys.argv]), "tasks": {}}
        print(
            f"epsilon {goal.config.epsilon:.2f} (standardised); task method t0: share dist within"
        )
        for task in names:
            demos = Demos.load(Path(args.demos) / f"{task}.npz")
            demos = demos.select(range(min(args.demos_used, len(demos))))
            for t0 in starts:
                res = track(fb, goal, demos, task, t0)
                table["tasks"].setdefault(task, {})[str(t0)] = res
                for m, r in res.items():
                    print(
                        f"{task:14} {m:9} {t0:4}: {r['return_share']:6.1%} "
                        f"{r['distance']:6.2f} {r['within']:6.1%}"
                    )
        if args.data:
            data = load_dataset(args.data, domain=goal.domain)
            res = reach(fb, goal, data, names[0], args.pairs, LOOKAHEAD)
            table["in_data"] = {"pairs": args.pairs, "horizon": LOOKAHEAD, **res}
            for m, r in res.items():
                print(
                    f"in the data, goal {LOOKAHEAD} steps ahead, {m:11}: reached "
                    f"{r['reached']:6.1%}, closest {r['closest']:5.2f}"
                )
        if args.json:
            atomic_write_text(args.json, json.dumps(table, indent=1) + "\n")
    except (FbilError, ValueError) as error:
        print(f"goal_tracking_probe: {error}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
