"""Feature and distribution matching of successor measures at expert states.

With F(s, z) the FB successor features and G_t the expert's discounted features along the
demonstration (both in B's coordinates, C = Cov B):
  FMFB (14): E_{rho_e} |C F(s_t, z) - G_t|^2                      (rewards spanned by B)
  DMFB (32): E_{rho_e} [F(s_t, z)^T C F(s_t, z) - 2 F(s_t, z)^T G_t]   (rewards in L2(rho))
"""

from __future__ import annotations

import torch

from fbil.imitation.core import DemoBatch, FBLike, gradient_method


def fm_loss(model: FBLike, batch: DemoBatch, z: torch.Tensor) -> torch.Tensor:
    f = model.forward(batch.obs, z.expand(len(batch.obs), -1))
    return batch.mean((f @ model.cov_b.T - batch.g).pow(2).sum(-1))


def dm_loss(model: FBLike, batch: DemoBatch, z: torch.Tensor) -> torch.Tensor:
    f = model.forward(batch.obs, z.expand(len(batch.obs), -1))
    return batch.mean(((f @ model.cov_b) * f).sum(-1) - 2 * (f * batch.g).sum(-1))


fmfb = gradient_method(fm_loss)
dmfb = gradient_method(dm_loss)
