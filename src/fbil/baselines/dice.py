"""What DemoDICE, SMODICE and LobsDICE share: a discriminator-derived log-ratio reward, a
convex dual over a state function nu on the unsupervised dataset D, and weighted BC.

1. Reward. ORIL's discriminator (`oril.py`: BCE, expert 1 and dataset 0, with a gradient
   penalty of Table 2's weight for the method and domain) on the method's input x, then
   r(x) = log D(x) - log(1 - D(x)), the logit: at the optimum log(rho_E(x) / rho_D(x))
   (App. B). x = (s, a) for DemoDICE, s' for SMODICE, (s, s') for LobsDICE. Options from
   the DemoDICE code, off by default: a bounded form of r (`reward_eps`) and a gradient
   penalty on nu (`nu_grad_penalty`).
2. Dual. With e(s, a, s') = r + gamma * discount * nu(s') - nu(s) and y = e / (1 + alpha),
   nu minimises over D's transitions and initial states s0 (the dataset's episode starts,
   oversampled windows left out: they start mid-episode, not at a reset;
   `initial_states="demos"`: the demos' first states alone)

     kl:        L(nu) = (1 - gamma) E_s0[nu(s0)] + (1 + alpha) log E_D[exp(y)]
     chi2:      L(nu) = (1 - gamma) E_s0[nu(s0)] + (1 + alpha) E_D[y^2 / 2 + y]
     chi2_plus: L(nu) = (1 - gamma) E_s0[nu(s0)] + (1 + alpha) E_D[f*_+(y)],

   y^2 / 2 + y the conjugate of f(x) = (x - 1)^2 / 2 over all reals (what SMODICE's code,
   JasonMa2016/SMODICE, minimises; rows with y < -1 keep pulling y up to -1), f*_+ its
   conjugate restricted to x >= 0: f*_+(y) = w y - f(w), w = max(0, y + 1) (-1/2 and no
   gradient below y = -1). kl and chi2_plus are exactly the dual of
   max_d E_d[r] - (1 + alpha) D_f(d || d_D) over d >= 0 satisfying the Bellman flow
   constraints (f(x) = x log x for kl, with sum d = 1); for kl and r = log(rho_E / rho_D)
   that is min_d KL(d || rho_E) + alpha KL(d || d_D). At their optimum, d = w d_D is an
   occupancy; chi2's optimum drops d >= 0, and its weights are clipped at 0 as the code's.
   D is the union of the unsupervised dataset and the demonstrations for DemoDICE, as the
   authors' code (geon-hyeong/imitation-dice: rows drawn uniformly from imperfect + expert
   data, initial states from both); the action-free methods (SMODICE, LobsDICE) cannot
   clone demo actions and use the dataset alone.
3. Policy. The stationary-distribution ratios w = exp(y) / E_D[exp(y)] (kl, normalised in
   the minibatch) or w = max(0, y + 1) (both chi2), held fixed, weight the Gaussian policy's BC:
   L(pi) = -E_D[w log pi(a|s)] (the policy of `bc.py`: tanh mean, state-dependent log-std;
   it plays its mean). nu and pi take one step each per minibatch.

Sizes: networks of 256 units (paper: 1024); nu has no gradient penalty of its own.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any, Literal

import numpy as np
import torch
from torch.nn import functional as F

from fbil.agents.td3 import _mlp, run_mlp
from fbil.baselines.bc import gaussian_log_prob, mean_action_policy
from fbil.baselines.common import (
    TrainedPolicy,
    Transitions,
    demo_transitions,
    paper_gamma,
    trained_imitator,
)
from fbil.baselines.offline_td3 import MixedSampler
from fbil.baselines.oril import Discriminator, DiscriminatorConfig, train_discriminator
from fbil.data.oversample import copy_sources
from fbil.errors import FbilError
from fbil.imitation.demos import Demos
from fbil.imitators.base import FitContext, Imitator
from fbil.imitators.budgets import Budgets

DIVERGENCES = ("kl", "chi2", "chi2_plus")
INITIAL_STATES = ("dataset", "demos")


@dataclass(frozen=True)
class DualConfig:
    divergence: str = "kl"
    alpha: float = 0.0  # weight of the divergence from the dataset's distribution
    steps: int = 20_000
    hidden: int = 256  # paper: 1024
    batch_size: int = 512
    lr: float = 1e-4
    # bf16 autocast on nu's and the policy's hidden layers (last layers fp32): 1.86x less
    # CPU per step at the maze size (benchmarks/baseline_update.py).
    precision: Literal["fp32", "bf16"] = "bf16"
    # Where the (1 - gamma) E[nu(s0)] term draws s0: the dataset's episode starts (and the
    # demos' first states for a union), or the demos' first states alone (`demos`).
    initial_states: Literal["dataset", "demos"] = "dataset"
    # r = -log(1 / (D + eps) - 1 + eps): eps 0 is the logit log D - log(1 - D) (the paper's
    # App. B); the DemoDICE/LobsDICE code (geon-hyeong/imitation-dice) uses eps 1e-3, which
    # bounds r to about [-6.9, 13.8].
    reward_eps: float = 0.0
    # Weight of mean |grad_s nu|^2 at the batch's states and at random points between
    # them and demo states (s and s'), as the same code (1e-4 there); 0: none.
    nu_grad_penalty: float = 0.0

    def __post_init__(self) -> None:
        if self.divergence not in DIVERGENCES:
            raise FbilError(
                f"unknown divergence {self.divergence!r}; valid: {', '.join(DIVERGENCES)}"
            )
        if self.initial_states not in INITIAL_STATES:
            raise FbilError(
                f"unknown initial_states {self.initial_states!r}; valid: "
                f"{', '.join(INITIAL_STATES)}"
            )


@dataclass(frozen=True)
class DiceConfig:
    dual: DualConfig = field(default_factory=DualConfig)
    discriminator: DiscriminatorConfig = field(default_factory=DiscriminatorConfig)


def smoke(dual: DualConfig) -> DiceConfig:
    """The smoke budget of a method whose cpu budget's dual is `dual`."""
    return DiceConfig(
        replace(dual, steps=20, hidden=32, batch_size=64),
        DiscriminatorConfig(steps=20, hidden=32, batch_size=64),
    )


def chi2_conjugate(y: torch.Tensor, restricted: bool = False) -> torch.Tensor:
    """f*(y) = y^2 / 2 + y for f(x) = (x - 1)^2 / 2 on all reals (SMODICE's code), or
    f*_+(y) with x restricted to x >= 0 (`restricted`: -1/2 and no gradient below -1)."""
    if not restricted:
        return 0.5 * y**2 + y
    w = F.relu(y + 1)
    return w * y - 0.5 * (w - 1) ** 2


def dual_loss(
    nu0: torch.Tensor,
    e: torch.Tensor,
    gamma: float,
    alpha: float,
    divergence: str,
) -> torch.Tensor:
    """L(nu) of the module's docstring from nu at initial states `nu0` and the rows'
    e = r + gamma * discount * nu(s') - nu(s)."""
    y = e / (1 + alpha)
    if divergence == "kl":
        spread = torch.logsumexp(y, 0) - math.log(len(y))
    else:
        spread = chi2_conjugate(y, restricted=divergence == "chi2_plus").mean()
    return (1 - gamma) * nu0.mean() + (1 + alpha) * spread


def dice_reward(logits: torch.Tensor, eps: float = 0.0) -> torch.Tensor:
    """r = -log(1 / (D + eps) - 1 + eps) for D = sigmoid(logits): the logit itself at eps 0,
    within about [log(eps), -2 log(eps)] otherwise."""
    if eps == 0:
        return logits
    d = torch.sigmoid(logits)
    return -torch.log(1 / (d + eps) - 1 + eps)


def dice_weights(e: torch.Tensor, alpha: float, divergence: str) -> torch.Tensor:
    """The ratios w = d / d_D of the rows, from their e (no gradient)."""
    y = e.detach() / (1 + alpha)
    if divergence == "kl":
        return torch.softmax(y, 0) * len(y)
    return F.relu(y + 1)


def effective_share(w: torch.Tensor) -> float:
    """The weights' effective sample size (sum w)^2 / sum w^2 as a share of the rows: 1 for
    uniform weights, 1/n when one row carries the whole weighted BC step."""
    return float(w.sum() ** 2 / (w * w).sum().clamp_min(1e-12)) / len(w)


def advantage(
    nu: Callable[[torch.Tensor], torch.Tensor],
    batch: Transitions,
    reward: torch.Tensor,
    gamma: float,
) -> torch.Tensor:
    """e = r + gamma * discount * nu(s') - nu(s); nu maps (B, d) states to (B, 1), and
    runs once on s and s' together."""
    n = len(batch.obs)
    both = nu(torch.cat([batch.obs, batch.next_obs])).squeeze(-1)
    return reward + gamma * batch.discount * both[n:] - both[:n]


class DiceLearner:
    """nu and the policy on standardised states, their optimisers and one joint update."""

    def __init__(
        self,
        disc: Discriminator,
        dataset: Any,
        cfg: DualConfig,
        reward_fn: Callable[[Transitions], torch.Tensor] | None = None,
    ) -> None:
        self.disc, self.cfg, self.stats = disc, cfg, disc.stats
        self.reward_fn = reward_fn
        obs_dim, self.act_dim = dataset.observation.shape[1], dataset.action.shape[1]
        self.gamma = paper_gamma(dataset.domain)
        self.nu_net = _mlp(obs_dim, cfg.hidden, 1)
        self.policy = _mlp(obs_dim, cfg.hidden, 2 * self.act_dim)
        self.nu_opt = torch.optim.Adam(self.nu_net.parameters(), lr=cfg.lr)
        self.policy_opt = torch.optim.Adam(self.policy.parameters(), lr=cfg.lr)

    def reward(self, batch: Transitions) -> torch.Tensor:
        """The rows' reward: the discriminator's log-ratio, or `reward_fn`'s when given."""
        if self.reward_fn is not None:
            return self.reward_fn(batch)
        return dice_reward(self.disc.logits(self.disc.features(batch)), self.cfg.reward_eps)

    def nu(self, obs: torch.Tensor) -> torch.Tensor:
        return run_mlp(self.nu_net, (obs - self.stats[0]) / self.stats[1], self.cfg.precision)

    def grad_penalty(self, batch: Transitions, expert: Transitions) -> torch.Tensor:
        """mean |grad nu|^2 at the batch's states and at random mixes of demo and batch
        states and of their next states (the DemoDICE code's regulariser of nu)."""
        pick = torch.randint(0, len(expert.obs), (len(batch.obs), 1))[:, 0]
        u = torch.rand(len(batch.obs), 1)
        mixed = [u * expert.obs[pick] + (1 - u) * batch.obs]
        mixed.append(u * expert.next_obs[pick] + (1 - u) * batch.next_obs)
        # On standardised states, the networks' input, as the code's normalised states.
        x = ((torch.cat([batch.obs, *mixed]) - self.stats[0]) / self.stats[1]).requires_grad_()
        out = run_mlp(self.nu_net, x, self.cfg.precision)
        (grad,) = torch.autograd.grad(out.sum(), x, create_graph=True)
        return (grad * grad).sum(-1).mean()

    def update(
        self, batch: Transitions, starts: torch.Tensor, expert: Transitions | None = None
    ) -> dict[str, float]:
        """One step on L(nu), then one on the weighted BC loss L(pi); `expert`: the demo
        transitions (for nu's gradient penalty)."""
        assert batch.action is not None
        cfg = self.cfg
        with torch.no_grad():
            reward = self.reward(batch)
        e = advantage(self.nu, batch, reward, self.gamma)
        loss = dual_loss(self.nu(starts), e, self.gamma, cfg.alpha, cfg.divergence)
        if cfg.nu_grad_penalty > 0 and expert is not None:
            loss = loss + cfg.nu_grad_penalty * self.grad_penalty(batch, expert)
        self.nu_opt.zero_grad(set_to_none=True)
        loss.backward()
        self.nu_opt.step()
        w = dice_weights(e, cfg.alpha, cfg.divergence)
        x = (batch.obs - self.stats[0]) / self.stats[1]
        out = run_mlp(self.policy, x, cfg.precision)
        p_loss = -(w * gaussian_log_prob(out, batch.action).sum(-1)).mean()
        self.policy_opt.zero_grad(set_to_none=True)
        p_loss.backward()
        self.policy_opt.step()
        return {
            "nu_loss": float(loss.detach()),
            "w_max": float(w.max()),
            "w_ess": effective_share(w),
            "r": float(reward.mean()),
        }


def reset_states(dataset: Any) -> torch.Tensor:
    """The dataset's episode starts that follow an environment reset: an oversampled window
    (`copy_sources`) starts mid-episode, so it is no initial state of the dual."""
    resets = dataset.episode_start[copy_sources(dataset) < 0]
    return torch.from_numpy(dataset.observation[resets])


def train_dice(
    name: str,
    kind: str,
    demos: Demos,
    dataset: Any,
    cfg: DiceConfig,
    penalty: float,
    seed: int,
    union: bool = False,
    on_step: Callable[[int, DiceLearner, dict[str, float]], None] | None = None,
    reward_fn: Callable[[Transitions], torch.Tensor] | None = None,
) -> TrainedPolicy:
    """The discriminator on input `kind` ("sa", "s", "ss"; gradient penalty `penalty`), then
    `cfg.dual.steps` joint nu and policy updates on minibatches of the dataset, or of the
    dataset and the demonstrations (`union`; they need actions). `on_step(step, learner,
    metrics)` is called after every update (diagnostics: learning curves); `reward_fn(batch)`
    replaces the discriminator's reward (diagnostics: the task's true reward as an oracle)."""
    disc_cfg = cfg.discriminator  # an explicit gradient_penalty (a --set) wins over Table 2's
    if disc_cfg.gradient_penalty is None:
        disc_cfg = replace(disc_cfg, gradient_penalty=penalty)
    disc = train_discriminator(kind, demos, dataset, disc_cfg, seed)
    torch.manual_seed(seed)
    gen = torch.Generator().manual_seed(seed + 1)
    learner = DiceLearner(disc, dataset, cfg.dual, reward_fn)
    starts = reset_states(dataset)
    first = [np.asarray(t.observation[:1], np.float32) for t in demos.trajectories]
    demo_starts = torch.from_numpy(np.concatenate(first))
    expert = demo_transitions(demos) if union else None
    expert_rows = None  # nu's gradient penalty mixes demo states in (nu_grad_penalty > 0)
    if cfg.dual.nu_grad_penalty > 0:
        expert_rows = expert if expert is not None else demo_transitions(demos)
    if cfg.dual.initial_states == "demos":
        starts = demo_starts
    elif union:
        starts = torch.cat([starts, demo_starts])
    # expert_ratio None: rows uniform over the union (or the dataset when expert is None).
    sample = MixedSampler(dataset, expert, cfg.dual.batch_size, None, gen)
    last: dict[str, float] = {}
    for step in range(1, cfg.dual.steps + 1):
        s0 = starts[torch.randint(0, len(starts), (cfg.dual.batch_size,), generator=gen)]
        last = learner.update(sample(), s0, expert_rows)
        if on_step is not None:
            on_step(step, learner, last)
    info = {k: round(v, 5) for k, v in last.items()}
    return mean_action_policy(
        name, learner.policy, learner.stats, learner.act_dim, info, cfg.dual.precision
    )


def dice_imitator(
    name: str,
    kind: str,
    principle: str,
    dual: DualConfig,
    penalty: dict[str, float],
    union: bool = False,
) -> Imitator:
    """A DICE method: its discriminator input `kind`, its dual's settings (the `cpu` budget;
    `smoke` shrinks them), its discriminator's gradient penalty per domain (Table 2) and
    whether its D holds the demonstrations too (`union`)."""
    budgets = Budgets(cpu=DiceConfig(dual), smoke=smoke(dual))

    def fit(demos: Demos, context: FitContext) -> TrainedPolicy:
        data, cfg = context.dataset, budgets[context.budget]
        weight = penalty.get(data.domain, 10.0)
        return train_dice(name, kind, demos, data, cfg, weight, context.seed, union)

    return trained_imitator(
        name, principle, fit, budgets, needs_actions=kind == "sa", needs_dataset=True
    )
