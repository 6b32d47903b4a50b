"""SQIL (Reddy et al. 2020), offline as the paper's App. B: reward r = 1 on expert
transitions and r = 0 on the unsupervised dataset's, learnt by SAC (`sac.py`) with
balanced sampling: every minibatch holds as many expert rows as dataset rows.

Objective: SAC's soft Bellman critic loss with y = r + gamma * discount * (min_i Q'_i(s',
a') - alpha log pi(a'|s')), r = 1[expert], and its entropy-regularised actor and learned
temperature (target entropy -act_dim; the paper does not give the temperature)."""

from __future__ import annotations

from dataclasses import dataclass, field

from fbil.baselines.common import TrainedPolicy, Transitions, demo_transitions, trained_imitator
from fbil.baselines.sac import SAC, SACConfig, train_sac
from fbil.baselines.td3il import LABEL_RANGE, labels
from fbil.imitation.demos import Demos
from fbil.imitators.base import FitContext
from fbil.imitators.budgets import Budgets


@dataclass(frozen=True)
class SQILConfig:
    sac: SACConfig = field(default_factory=SACConfig)
    expert_ratio: float = 0.5  # balanced sampling


BUDGETS = Budgets(
    cpu=SQILConfig(SACConfig(steps=30_000)),
    smoke=SQILConfig(SACConfig(steps=20, hidden=32, batch_size=64)),
)


def sqil_update(agent: SAC, batch: Transitions) -> dict[str, float]:
    """One SAC update on SQIL's labels."""
    reward = labels(batch)
    return {**agent.update(batch, reward), "reward_mean": float(reward.mean())}


def fit(demos: Demos, context: FitContext) -> TrainedPolicy:
    cfg = BUDGETS[context.budget]
    expert = demo_transitions(demos)
    agent, info = train_sac(
        context.dataset,
        sqil_update,
        cfg.sac,
        context.seed,
        expert,
        cfg.expert_ratio,
        checkpoint=context.checkpoint,
        reward_range=LABEL_RANGE,
    )
    return TrainedPolicy("sqil", agent.act, agent.state(), info, agent.cfg.precision)


IMITATOR = trained_imitator(
    "sqil", "reward (0/1 labels)", fit, BUDGETS, needs_actions=True, needs_dataset=True
)
