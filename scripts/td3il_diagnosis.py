"""TD3IL on one task (the maze unless `--domain`) with one thing changed at a time, to see
what bounds it: the share of expert rows in each minibatch (`--ratio`; the paper's 0.002),
the reward (`--reward true`: no demo, the dataset relabeled with the task's true reward,
i.e. the same offline TD3 as an oracle), the data (`--max-episodes`: the first N episodes
of the dataset) and the number of gradient steps. Everything else is td3il's `cpu` budget;
the demo is draw `--draw` (default 0) of K = 1, as `fbil benchmark` draws it.
`--eval-at N1,N2,..` also evaluates the policy after those updates of the same run (a
budget curve for the price of its longest point), and `--hidden` sets the networks'
width. `--learner sac --reward true` trains the offline SAC of sqil and iqlearn
(`fbil.baselines.sac`, sqil's `cpu` settings but `--steps`/`--hidden`) on the true reward
instead: the oracle those two baselines need before a grid. One thread; prints one JSON
line per evaluation. For TD3 each line also holds the critics' min(Q1, Q2) averaged over
the expert's (s, a) rows (`q_expert`), over 4 096 fixed dataset rows at their own actions
(`q_data`) and at the policy's (`q_pi_data`): whether the expert rows stay above the data
as training goes on.

Usage: python scripts/td3il_diagnosis.py TASK [--ratio R] [--reward {01,true}] [--steps N]
       [--eval-at N1,N2] [--hidden H] [--max-episodes N] [--episodes 20] [--learner td3]
       [--domain point_mass_maze] [--data DIR] [--demos DIR] [--draw 0]
       [--target-max X] [--bc-alpha A]   (TD3 only: TD targets clamped to [0, X]; TD3+BC)
       [--clamp-values]   (either learner: the budgets' `clamp_values`, from the reward's
                           range: [0, 1] for the labels, [0, reward_max] for a true reward)
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import time

import numpy as np
import torch

from fbil.agents.td3 import TD3
from fbil.baselines import sqil, td3il
from fbil.baselines.common import TrainedPolicy, Transitions, dataset_rows, demo_transitions
from fbil.baselines.offline_td3 import agent_state, train_offline_td3
from fbil.baselines.sac import SAC, train_sac
from fbil.data import load_dataset
from fbil.envs.registry import get_task
from fbil.envs.rollout import rollout
from fbil.evaluation.evaluate import demo_draw
from fbil.imitation import Demos


@torch.no_grad()
def q_values(agent: TD3, expert: Transitions | None, probe: Transitions) -> dict[str, float]:
    """Mean min(Q1, Q2) at the expert's (s, a), the probe rows' (s, a) and (s, pi(s))."""

    def q(obs: torch.Tensor, act: torch.Tensor) -> float:
        return round(float(agent._q(agent.critics, obs, act).min(-1).values.mean()), 3)

    assert probe.action is not None
    out = {
        "q_data": q(probe.obs, probe.action),
        "q_pi_data": q(probe.obs, agent._pi(agent.actor, probe.obs)),
    }
    if expert is not None and expert.action is not None:
        out["q_expert"] = q(expert.obs, expert.action)
    return out


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("task")
    p.add_argument("--ratio", type=float, default=td3il.BUDGETS["cpu"].expert_ratio)
    p.add_argument("--reward", choices=["01", "true"], default="01")
    p.add_argument("--steps", type=int, default=td3il.BUDGETS["cpu"].td3.steps)
    p.add_argument("--eval-at", default="", help="comma-separated update counts < --steps")
    p.add_argument("--hidden", type=int, default=td3il.BUDGETS["cpu"].td3.hidden)
    p.add_argument("--target-max", type=float, default=None, help="TD3: clamp targets to [0, X]")
    p.add_argument("--bc-alpha", type=float, default=None, help="TD3: TD3+BC's alpha")
    p.add_argument("--clamp-values", action="store_true", help="clamp TD targets (either learner)")
    p.add_argument("--max-episodes", type=int, default=None)
    p.add_argument("--episodes", type=int, default=20)
    p.add_argument("--domain", default="point_mass_maze")
    p.add_argument("--data", default="datasets/point_mass_maze/rnd_uniform_1000_x4")
    p.add_argument("--demos", default="artifacts/demos/point_mass_maze")
    p.add_argument("--learner", choices=["td3", "sac"], default="td3")
    p.add_argument("--draw", type=int, default=0, help="the demo draw (K = 1), as the grid's")
    args = p.parse_args()
    if args.learner == "sac" and args.reward != "true":
        p.error(
            "--learner sac is the true-reward oracle: add --reward true (sqil is `fbil benchmark`)"
        )
    if args.learner == "sac" and (args.target_max is not None or args.bc_alpha is not None):
        p.error("--target-max and --bc-alpha change TD3 (--learner td3)")
    if args.clamp_values and args.target_max is not None:
        p.error("--clamp-values sets the clamp from the reward's range: drop --target-max")
    torch.set_num_threads(1)
    data = load_dataset(args.data, max_episodes=args.max_episodes)
    cfg = dataclasses.replace(td3il.BUDGETS["cpu"].td3, steps=args.steps, hidden=args.hidden)
    if args.target_max is not None:
        cfg = dataclasses.replace(cfg, target_min=0.0, target_max=args.target_max)
    cfg = dataclasses.replace(cfg, bc_alpha=args.bc_alpha, clamp_values=args.clamp_values)
    expert: Transitions | None = None
    if args.reward == "01":
        expert = demo_transitions(
            demo_draw(Demos.load(f"{args.demos}/{args.task}.npz"), 1, args.draw)
        )
        label, reward_range = td3il.labels, td3il.LABEL_RANGE
    else:
        true = torch.from_numpy(data.reward(args.task))
        reward_range = (0.0, get_task(args.domain, args.task).reward_max)

        def label(batch: Transitions) -> torch.Tensor:
            assert batch.index is not None
            return true[batch.index]

    rows = torch.randperm(data.num_transitions, generator=torch.Generator().manual_seed(0))
    probe = dataset_rows(data, rows[:4096])
    started = time.time()
    eval_at = {int(n) for n in args.eval_at.split(",") if n}

    def report(steps: int, agent: TD3 | SAC, info: dict[str, float]) -> None:
        seconds = time.time() - started
        if isinstance(agent, SAC):
            policy = TrainedPolicy("sqil", agent.act, agent.state(), info, agent.cfg.precision)
        else:
            state = agent_state(agent)
            policy = TrainedPolicy("td3il", agent.act, state, info, agent.cfg.precision)
        returns = rollout(args.domain, args.task, policy, list(range(args.episodes)))
        ret = returns.reward.sum(-1)
        out = {
            "domain": args.domain,
            "task": args.task,
            "reward": args.reward,
            "learner": args.learner,
            "ratio": args.ratio if expert else None,
            "steps": steps,
            "hidden": args.hidden,
            "target_max": args.target_max,
            "bc_alpha": args.bc_alpha,
            "clamp_values": args.clamp_values,
            "episodes_of_data": int(data.num_episodes),
            "return_mean": round(float(np.mean(ret)), 1),
            "return_std": round(float(np.std(ret)), 1),
            "train_seconds": round(seconds, 1),  # evaluations of earlier points included
            "draw": args.draw,
            "info": info,
        }
        if isinstance(agent, TD3):
            out.update(q_values(agent, expert, probe))
        print(json.dumps(out), flush=True)

    def on_step(t: int, agent: TD3 | SAC) -> None:
        if t in eval_at and t < args.steps:
            report(t, agent, {})

    if args.learner == "sac":
        sac_cfg = dataclasses.replace(
            sqil.BUDGETS["cpu"].sac,
            steps=args.steps,
            hidden=args.hidden,
            clamp_values=args.clamp_values,
        )

        def update(agent: SAC, batch: Transitions) -> dict[str, float]:
            reward = label(batch).float()
            return {**agent.update(batch, reward), "reward_mean": float(reward.mean())}

        sac, info = train_sac(data, update, sac_cfg, 0, None, 0.0, on_step, None, reward_range)
        report(args.steps, sac, info)
        return
    ratio = args.ratio if expert else None
    agent, info = train_offline_td3(
        data, label, cfg, 0, expert, ratio, on_step, reward_range=reward_range
    )
    report(args.steps, agent, info)


if __name__ == "__main__":
    main()
