"""KL distribution matching (57): min_z -E_{rho_e} sum_k gamma^k ln F(s_t, z)^T B(s_{t+k+1}).

Only meaningful where the model's density F^T B is positive on the demonstration. Pairs
where it is not contribute a constant (the log is taken of max(F^T B, 1e-12)), so a few
of them are harmless; the method refuses a model for which they carry at least half of
the pairs' weight at the warm start."""

from __future__ import annotations

from typing import Any

import torch

from fbil.errors import FbilError
from fbil.imitation.core import DemoBatch, FBLike, OptimiserConfig, optimise_z

# The largest share of the pairs' weight (gamma^k) on which F^T B may be <= 0 at the warm
# start; those pairs are constant in the loss, so the rest must carry most of it.
MAX_NONPOSITIVE = 0.5


def _pair_weights(batch: DemoBatch) -> torch.Tensor:
    """(N, N): weight_t gamma^k for row t and its future row t + k of the same trajectory."""
    same = batch.traj[:, None] == batch.traj[None, :]
    k = batch.step[None, :] - batch.step[:, None]
    ahead = same & (k >= 0)
    return torch.where(ahead, batch.weight[:, None] * batch.gamma ** k.clamp(min=0).float(), 0.0)


def klfb(
    model: FBLike, batch: DemoBatch, z0: torch.Tensor, optimiser: OptimiserConfig, **_: Any
) -> tuple[torch.Tensor, dict[str, Any]]:
    pairs = _pair_weights(batch)  # rows t (all), columns t + k (all)

    def density(z: torch.Tensor, part: DemoBatch) -> torch.Tensor:
        return model.forward(part.obs, z.expand(len(part.obs), -1)) @ batch.b_next.T

    with torch.no_grad():
        start = density(model.project_z(z0), batch)
    share = float((pairs * (start <= 0)).sum() / pairs.sum())
    if share >= MAX_NONPOSITIVE:
        raise FbilError(
            f"klfb needs F(s,z)^T B(s') > 0 on the demonstration, but the model gives "
            f"non-positive values on {100 * share:.1f}% of the pairs' weight; use another method"
        )

    def loss(z: torch.Tensor, part: DemoBatch) -> torch.Tensor:
        # A minibatch keeps its rows' pairs, reweighted to its (uniform) row weights.
        rows = part.rows if part.rows is not None else torch.arange(len(batch.obs))
        w = pairs[rows] / batch.weight[rows, None] * part.weight[:, None]
        return -(w * torch.log(density(z, part).clamp(min=1e-12))).sum()

    return optimise_z(model, loss, batch, z0, optimiser)
