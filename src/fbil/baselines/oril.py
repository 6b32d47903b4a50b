"""ORIL (Zolna et al. 2020, as the paper's App. B): a discriminator D separates expert
transitions from the unsupervised dataset's (binary cross-entropy plus a gradient penalty,
no positive-unlabeled term), then offline TD3 learns the reward r = log(D + 1).

Three inputs to D: `oril` the state-action pair (s, a), `oril_o` the state alone,
`oril_oo` the state and the next state (s, s'). The state of `oril_o` is the transition's
next state s', as the paper's rewards r(s_{t+1}). `oril` trains TD3 on the union of the
demonstrations and the dataset; the action-free variants on the dataset alone.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Literal

import torch
from torch.nn import functional as F

from fbil.agents.td3 import _mlp, run_mlp
from fbil.baselines.common import (
    PAPER_GRADIENT_PENALTY,
    TrainedPolicy,
    Transitions,
    dataset_rows,
    demo_transitions,
    standardiser,
    trained_imitator,
)
from fbil.baselines.offline_td3 import OfflineTD3Config, agent_state, train_offline_td3
from fbil.imitation.demos import Demos
from fbil.imitators.base import FitContext, Imitator
from fbil.imitators.budgets import Budgets

INPUTS = {"oril": "sa", "oril_o": "s", "oril_oo": "ss"}
REWARD_RANGE = (0.0, math.log(2.0))  # of r = log(D + 1), D in (0, 1)


@dataclass(frozen=True)
class DiscriminatorConfig:
    steps: int = 20_000  # paper: 5e5
    hidden: int = 256  # paper: 1024
    batch_size: int = 512  # expert rows and as many dataset rows
    lr: float = 1e-4
    gradient_penalty: float | None = None  # None: Table 2's weight for the domain
    # bf16 autocast on the hidden layers (last layer fp32), as the RL learners: 1.8x less
    # CPU per step at the maze size (session 15, benchmarks/baseline_update.py).
    precision: Literal["fp32", "bf16"] = "bf16"


@dataclass(frozen=True)
class ORILConfig:
    td3: OfflineTD3Config = field(default_factory=OfflineTD3Config)
    discriminator: DiscriminatorConfig = field(default_factory=DiscriminatorConfig)


BUDGETS = Budgets(
    cpu=ORILConfig(),
    smoke=ORILConfig(
        OfflineTD3Config(steps=20, hidden=32, batch_size=64),
        DiscriminatorConfig(steps=20, hidden=32, batch_size=64),
    ),
)


class Discriminator:
    """D(x) = sigmoid(net(x)) on the variant's input x, states standardised by the
    dataset's statistics."""

    def __init__(
        self,
        kind: str,
        obs_stats: torch.Tensor,
        act_dim: int,
        hidden: int,
        precision: str = "fp32",
    ) -> None:
        self.kind, self.stats, self.precision = kind, obs_stats, precision
        obs_dim = obs_stats.shape[1]
        width = {"sa": obs_dim + act_dim, "s": obs_dim, "ss": 2 * obs_dim}[kind]
        self.net = _mlp(width, hidden, 1)

    def features(self, batch: Transitions) -> torch.Tensor:
        def norm(obs: torch.Tensor) -> torch.Tensor:
            return (obs - self.stats[0]) / self.stats[1]

        if self.kind == "sa":
            assert batch.action is not None
            return torch.cat([norm(batch.obs), batch.action], -1)
        if self.kind == "s":
            return norm(batch.next_obs)
        return torch.cat([norm(batch.obs), norm(batch.next_obs)], -1)

    def logits(self, x: torch.Tensor) -> torch.Tensor:
        return run_mlp(self.net, x, self.precision).squeeze(-1)

    def reward(self, batch: Transitions) -> torch.Tensor:
        """r = log(D + 1), in (0, log 2)."""
        return torch.log1p(torch.sigmoid(self.logits(self.features(batch))))


def discriminator_loss(
    disc: Discriminator,
    expert: torch.Tensor,
    data: torch.Tensor,
    penalty: float,
    gen: torch.Generator,
) -> torch.Tensor:
    """BCE (expert 1, dataset 0) + penalty * (|grad_x logit(x)| - 1)^2 at random points
    between paired expert and dataset inputs (the WGAN-GP penalty of GAIL-type methods)."""
    logits = disc.logits(torch.cat([expert, data]))  # one pass for both sets
    bce = F.binary_cross_entropy_with_logits(
        logits[: len(expert)], torch.ones(len(expert))
    ) + F.binary_cross_entropy_with_logits(logits[len(expert) :], torch.zeros(len(data)))
    alpha = torch.rand(len(expert), 1, generator=gen)
    mixed = (alpha * expert + (1 - alpha) * data).requires_grad_(True)
    (grad,) = torch.autograd.grad(disc.logits(mixed).sum(), mixed, create_graph=True)
    return bce + penalty * ((grad.norm(dim=-1) - 1) ** 2).mean()


def train_discriminator(
    kind: str, demos: Demos, dataset: Any, cfg: DiscriminatorConfig, seed: int
) -> Discriminator:
    """D trained for `cfg.steps` Adam steps on minibatches of expert and dataset rows."""
    torch.manual_seed(seed)
    gen = torch.Generator().manual_seed(seed)
    stats = standardiser(dataset.observation, 1e-3)
    disc = Discriminator(kind, stats, dataset.action.shape[1], cfg.hidden, cfg.precision)
    penalty = cfg.gradient_penalty
    if penalty is None:
        penalty = PAPER_GRADIENT_PENALTY.get(dataset.domain, 10.0)
    expert = disc.features(demo_transitions(demos))
    opt = torch.optim.Adam(disc.net.parameters(), lr=cfg.lr)
    n_data = int(dataset.num_transitions)
    for _ in range(cfg.steps):
        pick = torch.randint(0, len(expert), (cfg.batch_size,), generator=gen)
        rows = torch.randint(0, n_data, (cfg.batch_size,), generator=gen)
        data = disc.features(dataset_rows(dataset, rows))
        loss = discriminator_loss(disc, expert[pick], data, penalty, gen)
        opt.zero_grad(set_to_none=True)
        loss.backward()
        opt.step()
    disc.net.requires_grad_(False)
    return disc


def _imitator(name: str) -> Imitator:
    kind = INPUTS[name]

    def fit(demos: Demos, context: FitContext) -> TrainedPolicy:
        cfg = BUDGETS[context.budget]
        disc = train_discriminator(kind, demos, context.dataset, cfg.discriminator, context.seed)
        agent, info = train_offline_td3(
            context.dataset,
            disc.reward,
            cfg.td3,
            context.seed,
            expert=demo_transitions(demos) if kind == "sa" else None,
            checkpoint=context.checkpoint,
            reward_range=REWARD_RANGE,
        )
        return TrainedPolicy(name, agent.act, agent_state(agent), info, agent.cfg.precision)

    principle = {"sa": "reward (discriminator)", "s": "reward (state discr.)"}
    return trained_imitator(
        name,
        principle.get(kind, "reward (transition discr.)"),
        fit,
        BUDGETS,
        needs_actions=kind == "sa",
        needs_dataset=True,
    )


IMITATORS = [_imitator(name) for name in INPUTS]
