"""One offline-IL baseline on one task with fields of its `cpu` budget changed (`--set
PATH=VALUE`, a dotted path into the budget's configuration: `td3.bc_alpha=2.5`,
`discriminator.steps=40000`, `td3.steps=100000`), the rest as `fbil benchmark` runs it: demo
draw 0 of K = 1, seed 0, the method's own fit. One thread; prints one JSON line with the
returns of `--episodes` evaluation episodes and the time to policy. For methods whose
module keeps its budgets in `BUDGETS` (bc, dwbc, oril, oril_o, oril_oo, otr, sqil, td3il,
iqlearn); the DICE methods have scripts/dice_diagnosis.py.

Usage: python scripts/baseline_diagnosis.py METHOD TASK [--set PATH=VALUE ...]
       [--domain point_mass_maze] [--data DIR] [--demos DIR] [--episodes 20]
"""

from __future__ import annotations

import argparse
import dataclasses
import importlib
import json
import time
import types
from typing import Any

import numpy as np
import torch

from fbil.data import load_dataset
from fbil.envs.rollout import rollout
from fbil.evaluation.evaluate import demo_draw
from fbil.imitation import Demos
from fbil.imitators import get_imitator
from fbil.imitators.base import FitContext

MODULES = {"oril_o": "oril", "oril_oo": "oril"}  # method -> module, where they differ
BUDGET = "diagnosis"


def parse_value(text: str, current: Any) -> Any:
    """`text` as the type of the field's current value (none -> None, for optional fields)."""
    if text.lower() == "none":
        return None
    if isinstance(current, bool):
        return text.lower() in ("1", "true", "yes")
    if isinstance(current, int):
        return int(text)
    if current is None or isinstance(current, float):
        return float(text)
    return text


def with_change(config: Any, path: str, text: str) -> Any:
    """`config` (a dataclass) with the field at dotted `path` set from `text`."""
    head, _, rest = path.partition(".")
    names = [f.name for f in dataclasses.fields(config)]
    if head not in names:
        raise SystemExit(f"--set {path}: no field {head!r} in {type(config).__name__} ({names})")
    value = getattr(config, head)
    new = with_change(value, rest, text) if rest else parse_value(text, value)
    return dataclasses.replace(config, **{head: new})


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("method")
    p.add_argument("task")
    p.add_argument("--set", action="append", default=[], metavar="PATH=VALUE")
    p.add_argument("--domain", default="point_mass_maze")
    p.add_argument("--data", default="datasets/point_mass_maze/rnd_uniform_1000_x4")
    p.add_argument("--demos", default="artifacts/demos/point_mass_maze")
    p.add_argument("--episodes", type=int, default=20)
    args = p.parse_args()
    torch.set_num_threads(1)
    module: types.ModuleType = importlib.import_module(
        f"fbil.baselines.{MODULES.get(args.method, args.method)}"
    )
    config = module.BUDGETS["cpu"]
    for item in args.set:
        path, _, text = item.partition("=")
        config = with_change(config, path, text)
    module.BUDGETS[BUDGET] = config  # the fit reads module.BUDGETS[context.budget]
    imitator = get_imitator(args.method)
    data = load_dataset(args.data)
    demos = demo_draw(Demos.load(f"{args.demos}/{args.task}.npz"), 1, 0)
    started = time.perf_counter()
    policy = imitator.fit_policy(demos, FitContext(dataset=data, budget=BUDGET, seed=0))
    seconds = time.perf_counter() - started
    ret = rollout(args.domain, args.task, policy, list(range(args.episodes))).reward.sum(-1)
    out = {
        "method": args.method,
        "task": args.task,
        "changes": dict(item.partition("=")[::2] for item in args.set),
        "data": args.data,
        "return_mean": round(float(np.mean(ret)), 1),
        "return_std": round(float(np.std(ret)), 1),
        "train_seconds": round(seconds, 1),
        "info": getattr(policy, "info", {}),
    }
    print(json.dumps(out), flush=True)


if __name__ == "__main__":
    main()
