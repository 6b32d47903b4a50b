"""One DICE baseline on one task (any domain: `--data`, `--demos`) with settings of its
dual changed (`--set KEY=VALUE`, fields of `fbil.baselines.dice.DualConfig`, e.g.
initial_states=demos), the rest at the `cpu` budget; the demo is draw 0 of K = 1, as
`fbil benchmark` draws it. One thread; prints one JSON line with the returns of
`--episodes` evaluation episodes, and with `--eval-at S1,S2,...` one more line per listed
dual step (a learning curve from one run: the policy's return there, and the mean nu loss,
w_max and w_ess (the weights' effective sample size as a share of the batch) over the
steps since the last line).

Usage: python scripts/dice_diagnosis.py {demodice,smodice,lobsdice} TASK [--set K=V ...]
       [--eval-at 20000,50000] [--disc-steps N] [--penalty W] [--reward true --reward-scale S]
"""

from __future__ import annotations

import argparse
import copy
import dataclasses
import json
import time
from collections.abc import Callable
from typing import Any, NamedTuple

import numpy as np
import torch

from fbil.baselines import demodice, lobsdice, smodice
from fbil.baselines.bc import mean_action_policy
from fbil.baselines.common import Transitions
from fbil.baselines.dice import DiceConfig, DiceLearner, train_dice
from fbil.config import config_from_dict
from fbil.data import load_dataset
from fbil.envs.rollout import rollout
from fbil.evaluation.evaluate import demo_draw
from fbil.imitation import Demos

METHODS = {  # module, discriminator input, union of dataset and demos
    "demodice": (demodice, "sa", True),
    "smodice": (smodice, "s", False),
    "lobsdice": (lobsdice, "ss", False),
}


class Setup(NamedTuple):
    """What a DICE diagnostic trains: the method's discriminator input and union flag, the
    `--set` changes (typed), the data, the demo draw, the penalty and the full config (its
    dual with the changes applied)."""

    kind: str
    union: bool
    changes: dict[str, object]
    data: Any
    demos: Demos
    penalty: float
    cfg: DiceConfig
    reward_fn: Callable[[Transitions], torch.Tensor] | None


def add_setup_args(p: argparse.ArgumentParser) -> None:
    """The arguments `setup` reads (shared with dice_map.py)."""
    p.add_argument("method", choices=sorted(METHODS))
    p.add_argument("task")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    p.add_argument("--data", default="datasets/point_mass_maze/rnd_uniform_1000_x4")
    p.add_argument("--demos", default="artifacts/demos/point_mass_maze")
    p.add_argument("--disc-steps", type=int, default=None, help="default: the cpu budget's")
    p.add_argument("--penalty", type=float, default=None, help="default: Table 2's")
    p.add_argument(
        "--reward",
        choices=["discriminator", "true"],
        default="discriminator",
        help="true: the task's own reward times --reward-scale in place of the log-ratio "
        "(an oracle for the dual and the weighted BC; action-free methods only)",
    )
    p.add_argument("--reward-scale", type=float, default=1.0)


def setup(args: argparse.Namespace) -> Setup:
    """One thread; the method's dual with `--set` applied, the data, demo draw 0, the
    penalty (Table 2's unless `--penalty`) and the discriminator's steps."""
    torch.set_num_threads(1)
    module, kind, union = METHODS[args.method]
    base = dataclasses.asdict(module.DUAL)
    changes: dict[str, object] = {}
    for item in args.set:
        key, value = item.split("=", 1)
        changes[key] = type(base[key])(value) if key in base else value
    dual = config_from_dict(type(module.DUAL), {**base, **changes})
    data = load_dataset(args.data)
    demos = demo_draw(Demos.load(f"{args.demos}/{args.task}.npz"), 1, 0)
    penalty = module.PENALTY[data.domain] if args.penalty is None else args.penalty
    cfg = DiceConfig(dual)
    if args.disc_steps is not None:
        disc = dataclasses.replace(cfg.discriminator, steps=args.disc_steps)
        cfg = dataclasses.replace(cfg, discriminator=disc)
    reward_fn = None
    if args.reward == "true":
        if union:
            raise SystemExit("--reward true: the union's demo rows have no dataset reward")
        true = torch.from_numpy(data.reward(args.task)) * args.reward_scale

        def reward_fn(batch: Transitions) -> torch.Tensor:
            assert batch.index is not None
            return true[batch.index]

    return Setup(kind, union, changes, data, demos, penalty, cfg, reward_fn)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_setup_args(p)
    p.add_argument("--episodes", type=int, default=20)
    p.add_argument("--eval-at", default="", help="comma-separated dual steps")
    args = p.parse_args()
    su = setup(args)
    data, cfg, penalty = su.data, su.cfg, su.penalty
    dual = cfg.dual
    started = time.time()
    eval_at = {int(x) for x in args.eval_at.split(",") if x}
    window: list[dict[str, float]] = []

    def on_step(step: int, learner: DiceLearner, metrics: dict[str, float]) -> None:
        window.append(metrics)
        if step not in eval_at:
            return
        net = copy.deepcopy(learner.policy)
        stats, act_dim = learner.stats, learner.act_dim
        snap = mean_action_policy("snapshot", net, stats, act_dim, {}, dual.precision)
        snap_ret = rollout(data.domain, args.task, snap, list(range(args.episodes)))
        total = snap_ret.reward.sum(-1)
        line = {
            "step": step,
            "return_mean": round(float(np.mean(total)), 1),
            "return_std": round(float(np.std(total)), 1),
            **{k: round(float(np.mean([m[k] for m in window])), 4) for k in window[0]},
            "seconds": round(time.time() - started, 1),
        }
        print(json.dumps(line), flush=True)
        window.clear()

    policy = train_dice(
        args.method, su.kind, su.demos, data, cfg, penalty, 0, su.union, on_step, su.reward_fn
    )
    seconds = time.time() - started
    ret = rollout(data.domain, args.task, policy, list(range(args.episodes)))
    returns = ret.reward.sum(-1)
    out = {
        "method": args.method,
        "task": args.task,
        "changes": su.changes,
        "data": args.data,
        "disc_steps": cfg.discriminator.steps,
        "penalty": penalty,
        "reward": args.reward if args.reward == "discriminator" else f"true x {args.reward_scale}",
        "return_mean": round(float(np.mean(returns)), 1),
        "return_std": round(float(np.std(returns)), 1),
        "train_seconds": round(seconds, 1),
        "info": policy.info,
    }
    print(json.dumps(out), flush=True)


if __name__ == "__main__":
    main()
