"""DWBC (Xu et al. 2022): discriminator-weighted behaviour cloning on the demonstrations
(E) and the unsupervised dataset (O), as the paper's App. B: the discriminator sees the
policy being learnt.

A discriminator d(s, a, log pi(a|s)) = sigmoid(l), its third input the per-dimension
log-likelihoods of the current policy (no gradient to pi), clipped to [-20, 10] and scaled to
[0, 1], is trained with DWBC's positive-unlabeled loss on d clipped to [0.1, 0.9] (the
authors' discriminator clips its output, so rows past the clip give no gradient)

  L_d = eta E_E[-log d] + E_O[-log(1 - d)] - eta E_E[-log(1 - d)],

and, in the same step, the Gaussian policy of `bc.py` (tanh mean, state-dependent log-std)
with DWBC's weighted BC objective, d clipped to [0.1, 0.9] and held fixed:

  L_pi = alpha E_E[-log pi(a|s)] - E_E[-log pi(a|s) (eta / (d (1 - d)) + 1)]
         + E_O[-log pi(a|s) (1 / (1 - d) - 1) 1[d >= 0.5]].

As in the authors' code (ryanxhr/DWBC, `algos/DWBC.py`), a dataset pair counts only when the
discriminator finds it expert-like (d >= 0.5), with weight d / (1 - d) in [1, 9]; every other
dataset pair has weight 0. Session 13's version gave every dataset pair 1 / (1 - d) >= 1.1
and trained an unclipped discriminator, whose PU term -eta E_E[l] grows without bound: 8.5 %
on the maze against BC's 57.7 %; see docs/baselines.md (session 14) for the measurements
that separated the two causes. alpha = 10 as the authors' scripts, eta = 0.5. The policy
plays its mean action."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import torch

from fbil.agents.td3 import _mlp
from fbil.baselines.bc import gaussian_log_prob, mean_action_policy
from fbil.baselines.common import (
    TrainedPolicy,
    Transitions,
    demo_transitions,
    standardiser,
    trained_imitator,
)
from fbil.baselines.offline_td3 import MixedSampler
from fbil.imitation.demos import Demos
from fbil.imitators.base import FitContext
from fbil.imitators.budgets import Budgets

LOG_PI_RANGE = (-20.0, 10.0)  # DWBC's clip of the discriminator's log pi input
D_CLIP = (0.1, 0.9)  # DWBC's clip of d in the policy weights


@dataclass(frozen=True)
class DWBCConfig:
    steps: int = 20_000
    hidden: int = 256  # paper: 1024
    batch_size: int = 512  # expert rows and as many dataset rows
    lr: float = 1e-4
    alpha: float = 10.0
    eta: float = 0.5


BUDGETS = Budgets(
    cpu=DWBCConfig(),
    smoke=DWBCConfig(steps=20, hidden=32, batch_size=64),
)


def discriminator_loss(logit_e: torch.Tensor, logit_o: torch.Tensor, eta: float) -> torch.Tensor:
    """L_d of the module's docstring, from the logits l of expert and dataset rows, with
    d = sigmoid(l) clipped to `D_CLIP` as the authors' discriminator outputs it: a row
    whose d is past the clip gives no gradient, so the discriminator stops pushing expert
    rows beyond 0.9 and dataset rows below 0.1."""
    d_e, d_o = torch.sigmoid(logit_e).clamp(*D_CLIP), torch.sigmoid(logit_o).clamp(*D_CLIP)
    expert = -torch.log(d_e) + torch.log(1 - d_e)
    return eta * expert.mean() - torch.log(1 - d_o).mean()


def policy_weights(
    d_e: torch.Tensor, d_o: torch.Tensor, alpha: float, eta: float
) -> tuple[torch.Tensor, torch.Tensor]:
    """The weights of -log pi in L_pi, d clipped to `D_CLIP`: alpha - eta / (d (1 - d)) - 1
    on expert rows; d / (1 - d) on dataset rows with d >= 0.5, 0 on the others."""
    d_e, d_o = d_e.clamp(*D_CLIP), d_o.clamp(*D_CLIP)
    w_o = torch.where(d_o >= 0.5, d_o / (1 - d_o), torch.zeros_like(d_o))
    return alpha - eta / (d_e * (1 - d_e)) - 1, w_o


class DWBC:
    """The policy and discriminator networks, their optimisers and one joint update."""

    def __init__(self, stats: torch.Tensor, act_dim: int, cfg: DWBCConfig) -> None:
        obs_dim = stats.shape[1]
        self.stats, self.act_dim, self.cfg = stats, act_dim, cfg
        self.policy = _mlp(obs_dim, cfg.hidden, 2 * act_dim)
        self.disc = _mlp(obs_dim + 2 * act_dim, cfg.hidden, 1)
        self.policy_opt = torch.optim.Adam(self.policy.parameters(), lr=cfg.lr)
        self.disc_opt = torch.optim.Adam(self.disc.parameters(), lr=cfg.lr)

    def norm(self, obs: torch.Tensor) -> torch.Tensor:
        return (obs - self.stats[0]) / self.stats[1]

    def log_prob(self, rows: Transitions) -> torch.Tensor:
        assert rows.action is not None
        return gaussian_log_prob(self.policy(self.norm(rows.obs)), rows.action)

    def logits(self, rows: Transitions, log_prob: torch.Tensor) -> torch.Tensor:
        """l(s, a, log pi(a|s)), the log-likelihoods clipped and scaled to [0, 1]."""
        assert rows.action is not None
        low, high = LOG_PI_RANGE
        scaled = (log_prob.detach().clamp(low, high) - low) / (high - low)
        return self.disc(torch.cat([self.norm(rows.obs), rows.action, scaled], -1)).squeeze(-1)

    def update(self, expert: Transitions, data: Transitions) -> dict[str, float]:
        """One discriminator step (L_d), then one policy step (L_pi)."""
        lp_e, lp_o = self.log_prob(expert), self.log_prob(data)
        l_e, l_o = self.logits(expert, lp_e), self.logits(data, lp_o)
        d_loss = discriminator_loss(l_e, l_o, self.cfg.eta)
        self.disc_opt.zero_grad(set_to_none=True)
        d_loss.backward()
        self.disc_opt.step()
        w_e, w_o = policy_weights(
            torch.sigmoid(l_e.detach()), torch.sigmoid(l_o.detach()), self.cfg.alpha, self.cfg.eta
        )
        p_loss = -(w_e * lp_e.sum(-1)).mean() - (w_o * lp_o.sum(-1)).mean()
        self.policy_opt.zero_grad(set_to_none=True)
        p_loss.backward()
        self.policy_opt.step()
        return {"d_loss": float(d_loss.detach()), "p_loss": float(p_loss.detach())}


def train_dwbc(expert: Transitions, dataset: Any, cfg: DWBCConfig, seed: int) -> TrainedPolicy:
    """DWBC for `cfg.steps` updates on `cfg.batch_size` expert and dataset rows each."""
    torch.manual_seed(seed)
    gen = torch.Generator().manual_seed(seed)
    model = DWBC(standardiser(dataset.observation, 1e-3), dataset.action.shape[1], cfg)
    sample = MixedSampler(dataset, expert, 2 * cfg.batch_size, 0.5, gen)
    last: dict[str, float] = {}
    for _ in range(cfg.steps):
        batch = sample()
        last = model.update(batch.select(batch.expert), batch.select(~batch.expert))
    info = {k: round(v, 5) for k, v in last.items()}
    return mean_action_policy("dwbc", model.policy, model.stats, model.act_dim, info)


def fit(demos: Demos, context: FitContext) -> TrainedPolicy:
    expert = demo_transitions(demos)
    return train_dwbc(expert, context.dataset, BUDGETS[context.budget], context.seed)


IMITATOR = trained_imitator(
    "dwbc", "behavioral cloning (weighted)", fit, BUDGETS, needs_actions=True, needs_dataset=True
)
