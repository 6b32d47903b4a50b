"""Behavioral cloning through the FB policies: the pi_z under which expert actions are
most likely, (7): min_z -E_{rho_e} ln pi_z(a_t | s_t)."""

from __future__ import annotations

from typing import Any

import torch

from fbil.errors import FbilError
from fbil.imitation.core import DemoBatch, FBLike, OptimiserConfig, gradient_method


def bcfb(
    model: FBLike, batch: DemoBatch, z0: torch.Tensor, optimiser: OptimiserConfig, **_: Any
) -> tuple[torch.Tensor, dict[str, Any]]:
    if batch.action is None:
        raise FbilError(
            "bcfb needs expert actions, and these demonstrations have none; "
            "use an action-free method (e.g. erfb, goalfb)"
        )
    return gradient_method(bc_loss)(model, batch, z0, optimiser)


def bc_loss(model: FBLike, batch: DemoBatch, z: torch.Tensor) -> torch.Tensor:
    assert batch.action is not None
    return -batch.mean(model.log_prob(batch.obs, z.expand(len(batch.obs), -1), batch.action))
