"""A compact offline SAC (Haarnoja et al. 2018): twin critics with Polyak targets, a
tanh-Gaussian actor and a learned (or fixed) temperature, on standardised states.

For a batch (s, a, r, s', discount), with a' ~ pi(.|s') and a~ ~ pi(.|s) reparametrised:
  y      = r + gamma * discount * (min_i Q'_i(s', a') - alpha * log pi(a'|s'))
           (optionally clamped from above by the largest soft value: `clamp_values`)
  critic = sum_i mean (Q_i(s, a) - y)^2
  actor  = mean (alpha * log pi(a~|s) - min_i Q_i(s, a~))
  temp.  = -mean log_alpha * (log pi(a~|s) + target_entropy)   (target_entropy = -act_dim)
then the targets move by Polyak averaging. The networks are App. D's MLPs (`_mlp`).
`SAC.soft_value` and the separate critic and actor steps let IQ-Learn swap in its own
critic loss; SQIL uses `update` as is.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
import torch
from torch import nn
from torch.nn import functional as F

from fbil.agents.td3 import _mlp, run_mlp
from fbil.baselines.bc import LOG_STD
from fbil.baselines.common import (
    Transitions,
    paper_gamma,
    standardiser,
    value_bounds,
    value_check,
)
from fbil.baselines.offline_td3 import MixedSampler
from fbil.checkpoint import FitCheckpoint
from fbil.errors import FbilError


@dataclass(frozen=True)
class SACConfig:
    """Table 2's common settings (batch 512, Adam 1e-4, target momentum 0.99); width and
    steps shrunk for CPUs (paper: 1024 units)."""

    steps: int = 30_000
    hidden: int = 256
    batch_size: int = 512
    lr: float = 1e-4
    tau: float = 0.01
    temperature: float | None = None  # None: learned from `init_temperature`
    init_temperature: float = 0.1
    # bf16 autocast on the hidden layers (last layers, losses and Adam in fp32), as
    # `OfflineTD3Config.precision`; "fp32": plain.
    precision: Literal["fp32", "bf16"] = "bf16"
    # Clamp the soft TD target from above by the largest soft value the method's rewards
    # allow (`value_bounds` with the entropy bonus alpha * act_dim * log 2, the most a policy
    # on [-1, 1]^act_dim earns); False: no clamp. Not for IQ-Learn (no reward).
    clamp_values: bool = False


class SAC:
    def __init__(self, dataset: Any, cfg: SACConfig, seed: int) -> None:
        torch.manual_seed(seed)
        obs_dim, act_dim = dataset.observation.shape[1], dataset.action.shape[1]
        self.cfg, self.act_dim = cfg, act_dim
        self.gamma = paper_gamma(dataset.domain)
        self.stats = standardiser(dataset.observation, 1e-3)
        self.actor = _mlp(obs_dim, cfg.hidden, 2 * act_dim)
        self.critics = nn.ModuleList([_mlp(obs_dim + act_dim, cfg.hidden, 1) for _ in range(2)])
        self.targets = copy.deepcopy(self.critics).requires_grad_(False)
        start = cfg.temperature if cfg.temperature is not None else cfg.init_temperature
        self.log_alpha = torch.tensor(math.log(start), requires_grad=cfg.temperature is None)
        # fused: one kernel per step for all parameters (the same update as the loop).
        self.actor_opt = torch.optim.Adam(self.actor.parameters(), lr=cfg.lr, fused=True)
        self.critic_opt = torch.optim.Adam(self.critics.parameters(), lr=cfg.lr, fused=True)
        self.alpha_opt = torch.optim.Adam([self.log_alpha], lr=cfg.lr)
        self.gen = torch.Generator().manual_seed(seed)
        self.reward_range: tuple[float, float] | None = None  # set for `cfg.clamp_values`

    def value_max(self) -> float | None:
        """The largest soft value `reward_range` allows, with the entropy bonus at the
        current temperature; None without a range."""
        if self.reward_range is None:
            return None
        bonus = float(self.alpha) * self.act_dim * math.log(2.0)
        return value_bounds(self.reward_range, self.gamma, bonus)[1]

    def target_max(self) -> float | None:
        """The clamp of the soft TD target (`SACConfig.clamp_values`), or None."""
        if not self.cfg.clamp_values:
            return None
        if (top := self.value_max()) is None:
            raise FbilError("clamp_values needs the method's reward range; this one has none")
        return top

    @property
    def alpha(self) -> torch.Tensor:
        return self.log_alpha.detach().exp()

    def norm(self, obs: torch.Tensor) -> torch.Tensor:
        return (obs - self.stats[0]) / self.stats[1]

    def sample(self, obs: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """a = tanh(u), u ~ N(mean(s), std(s)) reparametrised, and log pi(a|s) (B,)."""
        out = run_mlp(self.actor, self.norm(obs), self.cfg.precision)
        mean, log_std = out[:, : self.act_dim], out[:, self.act_dim :].clamp(*LOG_STD)
        eps = torch.randn(mean.shape, generator=self.gen)
        u = mean + log_std.exp() * eps
        gauss = -(0.5 * eps**2 + log_std + 0.5 * math.log(2 * math.pi))
        squash = 2 * (math.log(2) - u - F.softplus(-2 * u))  # log(1 - tanh(u)^2)
        return torch.tanh(u), (gauss - squash).sum(-1)

    def q(self, nets: nn.ModuleList, obs: torch.Tensor, action: torch.Tensor) -> torch.Tensor:
        x = torch.cat([self.norm(obs), action], -1)
        return torch.cat([run_mlp(n, x, self.cfg.precision) for n in nets], -1)  # (B, 2)

    def soft_value(self, obs: torch.Tensor, nets: nn.ModuleList) -> torch.Tensor:
        """V(s) = min_i Q_i(s, a) - alpha log pi(a|s), one a ~ pi (no actor gradient)."""
        with torch.no_grad():
            action, log_pi = self.sample(obs)
        return self.q(nets, obs, action).min(-1).values - self.alpha * log_pi

    def step(self, opt: torch.optim.Optimizer, loss: torch.Tensor) -> float:
        opt.zero_grad(set_to_none=True)
        loss.backward()
        opt.step()
        return float(loss.detach())

    def actor_step(self, obs: torch.Tensor) -> dict[str, float]:
        """The actor step, then the temperature's (if learned), then the targets'."""
        action, log_pi = self.sample(obs)
        self.critics.requires_grad_(False)  # no critic weight gradients only to drop them
        try:
            q = self.q(self.critics, obs, action).min(-1).values
            actor_loss = self.step(self.actor_opt, (self.alpha * log_pi - q).mean())
        finally:
            self.critics.requires_grad_(True)
        if self.cfg.temperature is None:
            target = -float(self.act_dim)
            self.step(self.alpha_opt, -(self.log_alpha * (log_pi.detach() + target)).mean())
        with torch.no_grad():
            for p, t in zip(self.critics.parameters(), self.targets.parameters(), strict=True):
                t.lerp_(p, self.cfg.tau)
        return {"actor_loss": actor_loss, "alpha": float(self.alpha)}

    def update(self, batch: Transitions, reward: torch.Tensor) -> dict[str, float]:
        """One soft Bellman critic step on `reward`, then `actor_step`."""
        assert batch.action is not None
        with torch.no_grad():
            soft = self.soft_value(batch.next_obs, self.targets)
            y = reward + self.gamma * batch.discount * soft
            if (top := self.target_max()) is not None:
                y = y.clamp(max=top)
        q = self.q(self.critics, batch.obs, batch.action)
        critic_loss = self.step(self.critic_opt, ((q - y[:, None]) ** 2).mean(0).sum())
        q_mean = float(q.detach().mean())
        return {"critic_loss": critic_loss, "q": q_mean, **self.actor_step(batch.obs)}

    @torch.no_grad()
    def act(self, obs: np.ndarray) -> np.ndarray:
        """The actor's mean action tanh(mean(s))."""
        obs_t = torch.as_tensor(obs, dtype=torch.float32)
        out = run_mlp(self.actor, self.norm(obs_t), self.cfg.precision)
        return torch.tanh(out[:, : self.act_dim]).numpy()

    def state(self) -> dict[str, Any]:
        return {"actor": self.actor.state_dict(), "obs_stats": self.stats}

    TRAINED = ("actor", "critics", "targets", "actor_opt", "critic_opt", "alpha_opt")

    def train_state(self) -> dict[str, Any]:
        """Everything training changes: networks, targets, optimisers, temperature, RNG."""
        state = {name: getattr(self, name).state_dict() for name in self.TRAINED}
        return {**state, "log_alpha": self.log_alpha.detach().clone(), "gen": self.gen.get_state()}

    def load_train_state(self, state: dict[str, Any]) -> None:
        for name in self.TRAINED:
            getattr(self, name).load_state_dict(state[name])
        with torch.no_grad():
            self.log_alpha.copy_(state["log_alpha"])
        self.gen.set_state(state["gen"])


Update = Callable[[SAC, Transitions], dict[str, float]]  # one update on a minibatch


def train_sac(
    dataset: Any,
    update: Update,
    cfg: SACConfig,
    seed: int,
    expert: Transitions | None,
    ratio: float,
    on_step: Callable[[int, SAC], None] | None = None,
    checkpoint: FitCheckpoint | None = None,
    reward_range: tuple[float, float] | None = None,
) -> tuple[SAC, dict[str, float]]:
    """A SAC agent trained by `cfg.steps` calls of `update` on minibatches holding a share
    `ratio` of expert rows (none when `expert` is None: an oracle on relabeled data); the
    agent and the last update's numbers. `on_step(t, agent)` runs after update t
    (1-based), and `checkpoint` resumes and saves the loop, as in `train_offline_td3`.
    `reward_range`: the bounds of the rewards `update` uses (for `cfg.clamp_values`)."""
    agent = SAC(dataset, cfg, seed)
    agent.reward_range = reward_range
    agent.target_max()  # a clamp without a reward range fails here, before any update
    sample = MixedSampler(dataset, expert, cfg.batch_size, ratio, agent.gen)
    last: dict[str, float] = {}
    first = 1
    if checkpoint is not None and (saved := checkpoint.resume("sac")) is not None:
        agent.load_train_state(saved[1])
        first, last = saved[0] + 1, saved[2]
    for t in range(first, cfg.steps + 1):
        last = update(agent, sample())
        if checkpoint is not None:
            checkpoint.tick("sac", t, cfg.steps, agent.train_state, last)
        if on_step is not None:
            on_step(t, agent)
    info = {k: round(v, 5) for k, v in last.items()}
    if (top := agent.value_max()) is not None:
        info = value_check(info, top)
    return agent, info
