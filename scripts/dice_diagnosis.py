"""One DICE baseline on one maze task with settings of its dual changed (`--set
KEY=VALUE`, fields of `fbil.baselines.dice.DualConfig`, e.g. initial_states=demos), the
rest at the `cpu` budget; the demo is draw 0 of K = 1, as `fbil benchmark` draws it. One
thread; prints one JSON line with the returns of `--episodes` evaluation episodes.

Usage: python scripts/dice_diagnosis.py {demodice,smodice,lobsdice} TASK [--set K=V ...]
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import time

import numpy as np
import torch

from fbil.baselines import demodice, lobsdice, smodice
from fbil.baselines.dice import DiceConfig, train_dice
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


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("method", choices=sorted(METHODS))
    p.add_argument("task")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    p.add_argument("--episodes", type=int, default=20)
    p.add_argument("--data", default="datasets/point_mass_maze/rnd_uniform_1000_x4")
    p.add_argument("--demos", default="artifacts/demos/point_mass_maze")
    args = p.parse_args()
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
    penalty = module.PENALTY[data.domain]
    started = time.time()
    policy = train_dice(args.method, kind, demos, data, DiceConfig(dual), penalty, 0, union)
    seconds = time.time() - started
    ret = rollout("point_mass_maze", args.task, policy, list(range(args.episodes)))
    returns = ret.reward.sum(-1)
    out = {
        "method": args.method,
        "task": args.task,
        "changes": changes,
        "return_mean": round(float(np.mean(returns)), 1),
        "return_std": round(float(np.std(returns)), 1),
        "train_seconds": round(seconds, 1),
        "info": policy.info,
    }
    print(json.dumps(out), flush=True)


if __name__ == "__main__":
    main()
