"""TD3IL (paper App. B): SQIL's {0, 1} reward, 1 on expert transitions and 0 on the
unsupervised dataset's, learnt by offline TD3 on minibatches holding a fixed share of
expert rows (Table 2: 0.002, at least one row a minibatch; 0.05 in the `cpu` budget)."""

from __future__ import annotations

from dataclasses import dataclass, field

import torch

from fbil.baselines.common import (
    TrainedPolicy,
    Transitions,
    demo_transitions,
    trained_imitator,
)
from fbil.baselines.offline_td3 import OfflineTD3Config, agent_state, train_offline_td3
from fbil.imitation.demos import Demos
from fbil.imitators.base import FitContext
from fbil.imitators.budgets import Budgets


@dataclass(frozen=True)
class TD3ILConfig:
    td3: OfflineTD3Config = field(default_factory=OfflineTD3Config)
    expert_ratio: float = 0.002


# cpu: each demo transition must be seen about as often as in the paper's hours of GPU
# training; Table 2's 0.002 over 50 000 updates shows it ~50 times, 0.05 ~1 300 times
# (maze reach_top_left and loop, 2 draws: 32.6 % -> 70.4 %; docs/baselines.md, session 32).
BUDGETS = Budgets(
    cpu=TD3ILConfig(OfflineTD3Config(steps=50_000), expert_ratio=0.05),
    smoke=TD3ILConfig(OfflineTD3Config(steps=20, hidden=32, batch_size=64)),
)


def labels(batch: Transitions) -> torch.Tensor:
    """r = 1 on expert rows, 0 on the dataset's."""
    return batch.expert.float()


LABEL_RANGE = (0.0, 1.0)  # the bounds of `labels`


def fit(demos: Demos, context: FitContext) -> TrainedPolicy:
    cfg = BUDGETS[context.budget]
    agent, info = train_offline_td3(
        context.dataset,
        labels,
        cfg.td3,
        context.seed,
        expert=demo_transitions(demos),
        expert_ratio=cfg.expert_ratio,
        checkpoint=context.checkpoint,
        reward_range=LABEL_RANGE,
    )
    return TrainedPolicy("td3il", agent.act, agent_state(agent), info, agent.cfg.precision)


IMITATOR = trained_imitator(
    "td3il", "reward (0/1 labels)", fit, BUDGETS, needs_actions=True, needs_dataset=True
)
