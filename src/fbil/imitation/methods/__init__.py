"""The FB-IL methods, one small module per imitation principle, and their registry."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import torch

from fbil.imitation.core import DemoBatch, FBLike
from fbil.imitation.methods import bc, bellman, goal, kl, matching, reward


@dataclass(frozen=True)
class Method:
    name: str
    principle: str
    equation: str
    # (model, batch, **options) -> z (d,), or a schedule (T, d); gradient methods also take
    # the warm start and the optimiser through the options.
    infer: Callable[..., tuple[torch.Tensor, dict[str, Any]]]
    needs_actions: bool = False
    gradient: bool = False


METHODS: dict[str, Method] = {
    m.name: m
    for m in (
        Method("erfb", "reward inference", "(8)", reward.erfb),
        Method("rerfb", "reward inference", "(9)", reward.rerfb),
        Method("bcfb", "behavioral cloning", "(7)", bc.bcfb, needs_actions=True, gradient=True),
        Method("fmfb", "feature matching", "(14)", matching.fmfb, gradient=True),
        Method("dmfb", "distribution matching", "(32)", matching.dmfb, gradient=True),
        Method("bbellfb", "Bellman gap (B*)", "(16)", bellman.bbellfb, gradient=True),
        Method("fblossfb", "Bellman gap (L2)", "(39)", bellman.fblossfb, gradient=True),
        Method("goalfb", "goal tracking", "4.4", goal.goalfb),
        Method("klfb", "KL distribution matching", "(57)", kl.klfb, gradient=True),
    )
}
# The methods of the paper's main tables (KLFB is an appendix variant).
MAIN_METHODS = ["erfb", "rerfb", "bcfb", "fmfb", "dmfb", "bbellfb", "fblossfb", "goalfb"]

__all__ = ["MAIN_METHODS", "METHODS", "DemoBatch", "FBLike", "Method"]
