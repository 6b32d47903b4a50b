"""Zero-shot reward check: z_r = E[r(s') B(s')] over the dataset relabeled with a task's
reward, then roll out pi_{z_r}. This measures the model, independently of imitation."""

from __future__ import annotations

from typing import Any

import numpy as np
import torch
from tqdm.auto import tqdm

from fbil.data import Dataset
from fbil.envs import get_domain, rollout
from fbil.errors import FbilError
from fbil.fb.model import FBModel
from fbil.fb.policy import FBPolicy


@torch.no_grad()
def dataset_backward(model: FBModel, dataset: Dataset, chunk: int = 65_536) -> torch.Tensor:
    """B(s') of every transition's next state, (N, d)."""
    obs = dataset.observation[dataset.next_index]
    return torch.cat([model.backward(obs[i : i + chunk]) for i in range(0, len(obs), chunk)])


def zero_shot(
    model: FBModel,
    dataset: Dataset,
    tasks: list[str],
    episodes: int = 20,
    seed: int = 0,
    progress: bool = False,
) -> dict[str, Any]:
    spec = get_domain(dataset.domain)
    if model.domain not in (None, dataset.domain) or model.config.obs_dim != spec.obs_dim:
        trained_on = model.domain or f"observations of size {model.config.obs_dim}"
        raise FbilError(
            f"the model is for {trained_on}, the dataset {dataset.root} for {dataset.domain}; "
            "pass a dataset of the model's domain"
        )
    b = dataset_backward(model, dataset)
    out: dict[str, Any] = {"tasks": {}}
    for task in tqdm(tasks, disable=not progress, desc="zero-shot", unit="task"):
        r = torch.from_numpy(dataset.reward(task)).reshape(-1, 1)
        z = model.project_z((r * b).mean(0))
        seeds = [seed * 1_000_003 + 10_000 + i for i in range(episodes)]
        ep = rollout(dataset.domain, task, FBPolicy(model, z), seeds)
        returns = ep.returns
        out["tasks"][task] = {
            "return_mean": float(np.mean(returns)),
            "return_std": float(np.std(returns)),
            "episodes": episodes,
        }
    return out
