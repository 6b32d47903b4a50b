"""A policy of the FB model for a fixed z, as a batched rollout callable."""

from __future__ import annotations

import numpy as np
import torch

from fbil.fb.model import FBModel


class FBPolicy:
    """pi_z(s) = mu(s, z): `policy(obs[N, d], step) -> actions[N, a]`."""

    def __init__(self, model: FBModel, z: torch.Tensor) -> None:
        self.model = model
        self.z = model.project_z(z.detach()).reshape(1, -1)

    @torch.no_grad()
    def __call__(self, obs: np.ndarray, step: int) -> np.ndarray:
        o = torch.as_tensor(obs, dtype=torch.float32)
        return self.model.act(o, self.z.expand(len(o), -1)).numpy()
