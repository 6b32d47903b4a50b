"""Reward-based imitation: put a reward on expert states and read z off FB's formula."""

from __future__ import annotations

from typing import Any

import torch

from fbil.imitation.core import DemoBatch, FBLike


def erfb(model: FBLike, batch: DemoBatch, **_: Any) -> tuple[torch.Tensor, dict[str, Any]]:
    """(8) reward rho_e / rho: z = E_{rho_e}[B(s)]."""
    e_b = (batch.weight[:, None] * batch.b_next).sum(0)
    return model.project_z(e_b), {}


def rerfb(model: FBLike, batch: DemoBatch, **_: Any) -> tuple[torch.Tensor, dict[str, Any]]:
    """(9) reward rho_e / (rho + rho_e): z = C (C + E_{rho_e}[B B^T])^-1 E_{rho_e}[B]."""
    w, b = batch.weight[:, None], batch.b_next
    e_b = (w * b).sum(0)
    e_bbt = (w * b).T @ b
    c = model.cov_b.to(b.dtype)
    z = c @ torch.linalg.solve(c + e_bbt, e_b)
    return model.project_z(z), {}
