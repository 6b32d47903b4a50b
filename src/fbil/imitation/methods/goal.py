"""Goal tracking (paper 4.4): at step t, reach the demo's state k steps ahead,
z_t = B(s_{min(t + k, l)}). A non-stationary policy that copies one trajectory."""

from __future__ import annotations

from typing import Any

import torch

from fbil.imitation.core import DemoBatch, FBLike


def goalfb(
    model: FBLike, batch: DemoBatch, lookahead: int = 10, **_: Any
) -> tuple[torch.Tensor, dict[str, Any]]:
    first = batch.traj == 0  # goal tracking follows one trajectory: the first
    b = batch.b_next[first]  # B(s_1), ..., B(s_l)
    length = len(b)
    # z_t for t = 0..l: B(s_{t+k}) is row t + k - 1 of b (clipped to the last state).
    rows = torch.clamp(torch.arange(length + 1) + lookahead - 1, 0, length - 1)
    info = {
        "lookahead": lookahead,
        "trajectories_used": 1,
        "trajectories_given": int(batch.traj.max()) + 1,
    }
    return model.project_z(b[rows]), info
