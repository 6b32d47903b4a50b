"""Bellman-gap matching: find the pi_z whose successor measure best satisfies the expert's
Bellman equation M = P_e + gamma P_e M, on expert transitions (s_t, s_{t+1}).

With delta_t = F(s_t, z) - gamma sg[F(s_{t+1}, z)] (sg: stop-gradient) and C = Cov B:
  BBELLFB (16): E [-2 F(s_t, z)^T C B(s_{t+1}) + delta_t^T C^2 delta_t]   (norm |.|_B*)
  FBLOSSFB (39): E [-2 F(s_t, z)^T B(s_{t+1}) + delta_t^T C delta_t]      (norm L2(rho))
"""

from __future__ import annotations

import torch

from fbil.imitation.core import DemoBatch, FBLike, gradient_method


def _terms(model: FBLike, batch: DemoBatch, z: torch.Tensor) -> tuple[torch.Tensor, ...]:
    zz = z.expand(len(batch.obs), -1)
    f = model.forward(batch.obs, zz)
    with torch.no_grad():  # the target side: no graph to build
        f_next = model.forward(batch.next_obs, zz)
    return f, f - batch.gamma * f_next


def bbell_loss(model: FBLike, batch: DemoBatch, z: torch.Tensor) -> torch.Tensor:
    c = model.cov_b
    f, delta = _terms(model, batch, z)
    cross = (f * (batch.b_next @ c.T)).sum(-1)
    quad = ((delta @ c.T) ** 2).sum(-1)  # delta^T C^2 delta, C symmetric
    return batch.mean(-2 * cross + quad)


def fbloss_loss(model: FBLike, batch: DemoBatch, z: torch.Tensor) -> torch.Tensor:
    f, delta = _terms(model, batch, z)
    cross = (f * batch.b_next).sum(-1)
    quad = ((delta @ model.cov_b) * delta).sum(-1)
    return batch.mean(-2 * cross + quad)


bbellfb = gradient_method(bbell_loss)
fblossfb = gradient_method(fbloss_loss)
