"""TD3 (Fujimoto et al. 2018), optionally with TD3+BC's behaviour-cloning term
(Fujimoto & Gu 2021) for offline training. One readable file: networks, update, state.

Update, for a batch (s, a, r, s', discount):
  a'  = clip(pi_target(s') + clip(N(0, policy_noise), +-noise_clip), -1, 1)
  y   = r + discount * gamma * min(Q1_target, Q2_target)(s', a')
        (clamped to [target_min, target_max] when set: e.g. [0, 1/(1 - gamma)] for 0/1
        rewards, the range a fixed point can have, as HER's reference clips its target)
  critics regress y; every `policy_delay` updates the actor maximises Q1(s, pi(s))
  (or, with actor_q="min_noisy", min(Q1, Q2)(s, clip(pi(s) + clip(N(0, policy_noise)))))
  (offline with bc_alpha: maximise lambda Q1(s, pi(s)) - |pi(s) - a|^2,
  lambda = bc_alpha / mean|Q1|), then all targets move by Polyak averaging.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
import torch
from torch import nn
from torch.nn import functional as F

from fbil.agents.two_stream import TwoStreamActor, TwoStreamCritic
from fbil.errors import FbilError


@dataclass(frozen=True)
class TD3Config:
    hidden: int = 256
    batch_size: int = 256
    lr: float = 3e-4
    gamma: float = 0.99
    tau: float = 0.005
    policy_noise: float = 0.2
    noise_clip: float = 0.5
    policy_delay: int = 2
    bc_alpha: float | None = None  # TD3+BC's alpha (offline); None: plain TD3
    # The actor's objective: "q1" is Fujimoto's Q1(s, pi(s)); "min_noisy" is the smoothed,
    # more conservative min(Q1, Q2)(s, pi(s) + clipped noise) of Meta's offline DDPG-style
    # agent (docs/td3-reference-audit.md, D5).
    actor_q: Literal["q1", "min_noisy"] = "q1"
    target_min: float | None = None  # None: the TD target is not clamped from below
    target_max: float | None = None  # None: nor from above
    exploration_noise: float = 0.2  # online: Gaussian noise on actions while collecting
    # n-step returns along episodes (the dataset's offline, the replay buffer's online).
    # The maze's mass moves ~2 mm per step, so n steps of exploration data end close to
    # where n expert steps would (small bias), while the value crosses the maze in n
    # times fewer backups; online, n = 3 speeds up locomotion as in DrQ-v2.
    nstep: int = 1
    # "bf16": hidden layers under bf16 autocast (AVX-512 BF16 matmuls at ~4x the fp32
    # rate on these CPUs), last layers, losses and optimiser in fp32; "fp32": plain.
    precision: Literal["fp32", "bf16"] = "fp32"
    # Online with a dataset (`fbil expert --mode online --data DIR`): the share of each
    # minibatch drawn from the dataset relabeled with the task, the rest from the replay
    # buffer (RLPD's symmetric sampling, Ball et al. 2023: prior data shows the learner
    # rewarded states its own exploration may never reach).
    offline_share: float = 0.5
    # The networks: "mlp", two hidden layers on the flat input; "two_stream", the paper's
    # conditioned networks (`fbil.agents.two_stream`), for an input [s, c] whose last
    # `cond_dim` entries condition the policy (GOAL-TD3's goal).
    arch: Literal["mlp", "two_stream"] = "mlp"
    cond_dim: int = 0

    def __post_init__(self) -> None:
        if self.arch not in ("mlp", "two_stream"):
            raise FbilError(f"unknown arch {self.arch!r}; valid: mlp, two_stream")
        if self.arch == "two_stream" and self.cond_dim < 1:
            raise FbilError("arch two_stream needs cond_dim >= 1 (the conditioning's size)")
        if self.precision not in ("fp32", "bf16"):
            raise FbilError(f"unknown precision {self.precision!r}; valid: fp32, bf16")
        if self.actor_q not in ("q1", "min_noisy"):
            raise FbilError(f"unknown actor_q {self.actor_q!r}; valid: q1, min_noisy")
        if self.policy_delay < 1:
            raise FbilError(f"policy_delay must be >= 1, got {self.policy_delay}")
        lo, hi = self.target_min, self.target_max
        if lo is not None and hi is not None and lo >= hi:
            raise FbilError(f"target_min ({lo}) must be below target_max ({hi})")
        if not 0 <= self.offline_share < 1:
            raise FbilError(f"offline_share must be in [0, 1), got {self.offline_share}")


def _mlp(inp: int, hidden: int, out: int) -> nn.Sequential:
    # Layer norm + tanh on the first layer standardises raw states (as the paper's nets).
    return nn.Sequential(
        nn.Linear(inp, hidden),
        nn.LayerNorm(hidden),
        nn.Tanh(),
        nn.Linear(hidden, hidden),
        nn.ReLU(),
        nn.Linear(hidden, out),
    )


def run_mlp(mlp: nn.Module, x: torch.Tensor, precision: str) -> torch.Tensor:
    """An MLP of `_mlp` or a two-stream net; with bf16, its hidden layers under autocast
    and its last layer in fp32 (Q values near 100 keep their resolution: bf16 has 8 bits
    of mantissa)."""
    if precision == "fp32":
        return mlp(x)
    if isinstance(mlp, TwoStreamActor | TwoStreamCritic):
        with torch.autocast("cpu", torch.bfloat16):
            features = mlp.features(x)
        return mlp.out(features.float())
    layers = list(mlp.children())
    with torch.autocast("cpu", torch.bfloat16):
        for layer in layers[:-1]:
            x = layer(x)
    return layers[-1](x.float())


def _actor_net(obs_dim: int, act_dim: int, cfg: TD3Config) -> nn.Module:
    if cfg.arch == "two_stream":
        return TwoStreamActor(obs_dim - cfg.cond_dim, cfg.cond_dim, act_dim, cfg.hidden)
    return _mlp(obs_dim, cfg.hidden, act_dim)


def _critic_net(obs_dim: int, act_dim: int, cfg: TD3Config) -> nn.Module:
    if cfg.arch == "two_stream":
        return TwoStreamCritic(obs_dim - cfg.cond_dim, cfg.cond_dim, act_dim, cfg.hidden)
    return _mlp(obs_dim + act_dim, cfg.hidden, 1)


class TD3:
    def __init__(
        self,
        obs_dim: int,
        act_dim: int,
        config: TD3Config,
        seed: int = 0,
    ) -> None:
        torch.manual_seed(seed)
        self.cfg, self.obs_dim, self.act_dim = config, obs_dim, act_dim
        self.actor = nn.Sequential(_actor_net(obs_dim, act_dim, config), nn.Tanh())
        self.critics = nn.ModuleList([_critic_net(obs_dim, act_dim, config) for _ in range(2)])
        self.actor_target = copy.deepcopy(self.actor).requires_grad_(False)
        self.critic_targets = copy.deepcopy(self.critics).requires_grad_(False)
        # fused: one kernel per step for all parameters instead of a loop over them.
        self.actor_opt = torch.optim.Adam(self.actor.parameters(), lr=config.lr, fused=True)
        self.critic_opt = torch.optim.Adam(self.critics.parameters(), lr=config.lr, fused=True)
        self.gen = torch.Generator().manual_seed(seed)
        self.updates = 0
        # Observation standardisation (mean, std), as TD3+BC: offline, the maze's positions
        # span +-0.3 and a net on raw inputs learns a value that is too smooth to see walls.
        self.obs_stats = torch.stack([torch.zeros(obs_dim), torch.ones(obs_dim)])

    def set_obs_stats(self, observations: np.ndarray) -> None:
        """Standardise inputs by the mean and std of `observations` (a dataset)."""
        obs = torch.as_tensor(observations, dtype=torch.float64)
        self.obs_stats = torch.stack([obs.mean(0), obs.std(0).clamp_min(1e-3)]).float()

    def _norm(self, obs: torch.Tensor) -> torch.Tensor:
        return (obs - self.obs_stats[0]) / self.obs_stats[1]

    def _run(self, mlp: nn.Module, x: torch.Tensor) -> torch.Tensor:
        return run_mlp(mlp, x, self.cfg.precision)

    def _pi(self, net: nn.Sequential, obs: torch.Tensor) -> torch.Tensor:
        return torch.tanh(self._run(net[0], self._norm(obs)))

    def _q(self, nets: nn.ModuleList, obs: torch.Tensor, act: torch.Tensor) -> torch.Tensor:
        x = torch.cat([self._norm(obs), act], -1)
        return torch.cat([self._run(n, x) for n in nets], -1)  # (B, 2)

    @torch.no_grad()
    def act(self, obs: np.ndarray, noise: float = 0.0) -> np.ndarray:
        a = self._pi(self.actor, torch.as_tensor(obs, dtype=torch.float32))
        if noise > 0:
            a = a + noise * torch.randn(a.shape, generator=self.gen)
        return a.clamp(-1, 1).numpy()

    def update(
        self,
        obs: torch.Tensor,
        action: torch.Tensor,
        reward: torch.Tensor,
        next_obs: torch.Tensor,
        discount: torch.Tensor,
    ) -> dict[str, float]:
        """One critic step; every `policy_delay` updates, an actor step and the targets."""
        eps = torch.randn(action.shape, generator=self.gen) * self.cfg.policy_noise
        loss, q = self.critic_loss(obs, action, reward, next_obs, discount, eps)
        self.critic_opt.zero_grad(set_to_none=True)
        loss.backward()
        self.critic_opt.step()
        self.updates += 1
        metrics = {"critic_loss": float(loss.detach()), "q": float(q)}
        if self.updates % self.cfg.policy_delay == 0:
            metrics["actor_loss"] = self.update_actor(obs, action)
            self.update_targets()
        return metrics

    def update_actor(self, obs: torch.Tensor, action: torch.Tensor) -> float:
        # The critics leave the graph for this loss: they receive no gradient, and the
        # backward computes no critic weight gradients only to drop them.
        self.critics.requires_grad_(False)
        try:
            loss = self.actor_loss(obs, action)
            self.actor_opt.zero_grad(set_to_none=True)
            loss.backward()
        finally:
            self.critics.requires_grad_(True)
        self.actor_opt.step()
        return float(loss.detach())

    @torch.no_grad()
    def update_targets(self) -> None:
        for net, tgt in ((self.actor, self.actor_target), (self.critics, self.critic_targets)):
            torch._foreach_lerp_(list(tgt.parameters()), list(net.parameters()), self.cfg.tau)

    def _smoothed(self, action: torch.Tensor, eps: torch.Tensor) -> torch.Tensor:
        """TD3's target policy smoothing: the action plus clipped noise, kept in [-1, 1]."""
        clip = self.cfg.noise_clip
        return (action + eps.clamp(-clip, clip)).clamp(-1, 1)

    def critic_loss(
        self,
        obs: torch.Tensor,
        action: torch.Tensor,
        reward: torch.Tensor,
        next_obs: torch.Tensor,
        discount: torch.Tensor,
        eps: torch.Tensor,
    ) -> tuple[torch.Tensor, torch.Tensor]:
        """Both critics' squared TD errors against the clipped double-Q target, and mean Q."""
        cfg = self.cfg
        with torch.no_grad():
            next_action = self._smoothed(self._pi(self.actor_target, next_obs), eps)
            next_q = self._q(self.critic_targets, next_obs, next_action).min(-1).values
            target = reward + discount * cfg.gamma * next_q
            if cfg.target_min is not None or cfg.target_max is not None:
                target = target.clamp(cfg.target_min, cfg.target_max)
        q = self._q(self.critics, obs, action)
        loss = F.mse_loss(q[:, 0], target) + F.mse_loss(q[:, 1], target)
        return loss, q.detach().mean()

    def actor_loss(self, obs: torch.Tensor, action: torch.Tensor) -> torch.Tensor:
        """-Q(s, pi(s)) (Q1, or min(Q1, Q2) at a noisy pi(s) with actor_q="min_noisy"); with
        bc_alpha, TD3+BC's -lambda Q + |pi(s) - a|^2."""
        pi = self._pi(self.actor, obs)
        if self.cfg.actor_q == "min_noisy":
            eps = torch.randn(pi.shape, generator=self.gen) * self.cfg.policy_noise
            q_pi = self._q(self.critics, obs, self._smoothed(pi, eps)).min(-1).values
        else:
            q_pi = self._run(self.critics[0], torch.cat([self._norm(obs), pi], -1)).squeeze(-1)
        if self.cfg.bc_alpha is None:
            return -q_pi.mean()
        lam = self.cfg.bc_alpha / q_pi.abs().mean().detach()
        return -lam * q_pi.mean() + F.mse_loss(pi, action)

    def state(self) -> dict[str, Any]:
        return {
            "actor": self.actor.state_dict(),
            "critics": self.critics.state_dict(),
            "actor_target": self.actor_target.state_dict(),
            "critic_targets": self.critic_targets.state_dict(),
            "actor_opt": self.actor_opt.state_dict(),
            "critic_opt": self.critic_opt.state_dict(),
            "gen": self.gen.get_state(),
            "updates": self.updates,
            "obs_stats": self.obs_stats,
        }

    def load(self, state: dict[str, Any]) -> None:
        for name in (
            "actor",
            "critics",
            "actor_target",
            "critic_targets",
            "actor_opt",
            "critic_opt",
        ):
            getattr(self, name).load_state_dict(state[name])
        self.gen.set_state(state["gen"])
        self.updates = int(state["updates"])
        if "obs_stats" in state:  # experts saved before standardisation have none
            self.obs_stats = state["obs_stats"].float()
