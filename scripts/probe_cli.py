"""The command line shared by the model probes (`z_probe.py`, `implied_reward_probe.py`):
a model, its dataset, a demos folder and the tasks; `load` reads them."""

from __future__ import annotations

import argparse
from typing import Any

import torch

from fbil.data import load_dataset
from fbil.envs import get_domain
from fbil.fb.model import FBModel


def probe_parser(description: str) -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(description=description)
    p.add_argument("model")
    p.add_argument("--data", required=True)
    p.add_argument("--demos", required=True)
    p.add_argument("--tasks", default="all")
    p.add_argument("--episodes", type=int, default=10)
    p.add_argument("--threads", type=int, default=1)
    p.add_argument("--json", default=None, help="also write the table to this JSON file")
    return p


def load(args: argparse.Namespace) -> tuple[FBModel, Any, list[str]]:
    """The model, the dataset and the task names (all of the domain's for `all`)."""
    torch.set_num_threads(args.threads)
    model, data = FBModel.load(args.model), load_dataset(args.data)
    tasks = get_domain(data.domain).task_names if args.tasks == "all" else args.tasks.split(",")
    return model, data, list(tasks)
