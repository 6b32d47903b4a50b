"""RND exploration (Burda et al. 2019) with a DDPG-style actor-critic, as ExORL collected
its unsupervised datasets, sized for CPUs.

A fixed random *target* network embeds normalised observations; a *predictor* learns to
match it on visited states, so its error is high on novel states. That error, divided by
its running standard deviation, is the intrinsic reward an off-policy actor-critic
(twin critics, target policy smoothing, Polyak targets) maximises online. Read top to
bottom: networks, replay, then `RNDExplorer.act` (acting + learning) and `update`.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np
import torch
from torch import nn
from torch.nn import functional as F


@dataclass(frozen=True)
class RNDConfig:
    # CPU-sized (ExORL: hidden 1024, rnd_dim 512, batch 1024); an update costs ~2 ms here.
    hidden: int = 128
    rnd_dim: int = 64  # output size of the target and predictor networks
    batch_size: int = 128
    lr: float = 3e-4
    discount: float = 0.99
    nstep: int = 3  # n-step returns, as ExORL's DDPG
    tau: float = 0.01  # Polyak rate of the critic targets
    stddev: float = 0.2  # exploration and target-smoothing noise
    # Population: agent k explores with noise spaced evenly from stddev to stddev_max
    # (distributed explorers with different noise levels, as in Ape-X).
    stddev_max: float = 0.2
    stddev_clip: float = 0.3
    updates_per_step: int = 1  # gradient updates of each agent per update round
    update_every: int = 2  # lockstep steps between update rounds
    agents: int = 4  # independent explorers, each driving num_envs / agents environments
    seed_steps: int = 2000  # per environment: uniform random actions before learning
    replay_capacity: int = 500_000
    num_envs: int = 8


def mlp(inp: int, hidden: int, out: int) -> nn.Sequential:
    return nn.Sequential(
        nn.Linear(inp, hidden),
        nn.ReLU(),
        nn.Linear(hidden, hidden),
        nn.ReLU(),
        nn.Linear(hidden, out),
    )


class RunningNorm:
    """Running mean and variance (Chan et al.'s parallel update) of a stream of batches."""

    def __init__(self, shape: tuple[int, ...]) -> None:
        self.mean = torch.zeros(shape)
        self.var = torch.ones(shape)
        self.count = torch.tensor(1e-4)

    def update(self, x: torch.Tensor) -> None:
        b_mean, b_var, b_count = x.mean(0), x.var(0, unbiased=False), x.shape[0]
        delta, total = b_mean - self.mean, self.count + b_count
        self.mean = self.mean + delta * b_count / total
        m2 = self.var * self.count + b_var * b_count + delta**2 * self.count * b_count / total
        self.var, self.count = m2 / total, total

    def state(self) -> dict[str, torch.Tensor]:
        return {"mean": self.mean, "var": self.var, "count": self.count}

    def load(self, state: dict[str, torch.Tensor]) -> None:
        self.mean, self.var, self.count = state["mean"], state["var"], state["count"]


class Replay:
    """Ring buffer of n-step transitions: (obs, action, the next n states, how many of
    them are real). Near an episode's end fewer than n follow; the rest repeat the last."""

    def __init__(self, capacity: int, obs_dim: int, act_dim: int, nstep: int) -> None:
        self.obs = np.zeros((capacity, obs_dim), np.float32)
        self.action = np.zeros((capacity, act_dim), np.float32)
        self.next_seq = np.zeros((capacity, nstep, obs_dim), np.float32)
        self.n_valid = np.zeros(capacity, np.int64)
        self.capacity, self.size, self.pos, self.nstep = capacity, 0, 0, nstep

    def add(self, obs: np.ndarray, action: np.ndarray, next_seq: np.ndarray, k: int) -> None:
        i = (self.pos + np.arange(len(obs))) % self.capacity
        self.obs[i], self.action[i], self.next_seq[i], self.n_valid[i] = obs, action, next_seq, k
        self.pos = int(i[-1] + 1) % self.capacity
        self.size = min(self.size + len(obs), self.capacity)

    def add_steps(self, observation: np.ndarray, action: np.ndarray, steps: range) -> None:
        """Transitions starting at `steps` of episodes observation (N, T+1, d), action
        (N, T, a)."""
        t_len = action.shape[1]
        for t in steps:
            k = min(self.nstep, t_len - t)
            seq = observation[:, t + 1 : t + 1 + k]
            pad = np.repeat(seq[:, -1:], self.nstep - k, axis=1)
            self.add(observation[:, t], action[:, t], np.concatenate([seq, pad], axis=1), k)

    def sample(self, n: int, rng: np.random.Generator) -> tuple[torch.Tensor, ...]:
        i = rng.integers(0, self.size, n)
        return (
            torch.from_numpy(self.obs[i]),
            torch.from_numpy(self.action[i]),
            torch.from_numpy(self.next_seq[i]),
            torch.from_numpy(self.n_valid[i]),
        )


class RNDExplorer:
    """A batched policy `(obs, step) -> actions` that learns while it acts."""

    def __init__(self, obs_dim: int, act_dim: int, config: RNDConfig, seed: int) -> None:
        self.cfg, self.act_dim = config, act_dim
        torch.manual_seed(seed)
        self.rng = np.random.default_rng(seed)
        h = config.hidden
        self.actor = nn.Sequential(mlp(obs_dim, h, act_dim), nn.Tanh())
        self.critics = nn.ModuleList([mlp(obs_dim + act_dim, h, 1) for _ in range(2)])
        self.critic_targets = nn.ModuleList([mlp(obs_dim + act_dim, h, 1) for _ in range(2)])
        self.critic_targets.load_state_dict(self.critics.state_dict())
        self.rnd_target = mlp(obs_dim, h, config.rnd_dim).requires_grad_(False)
        self.rnd_predictor = mlp(obs_dim, h, config.rnd_dim)
        self.actor_opt = torch.optim.Adam(self.actor.parameters(), lr=config.lr)
        self.critic_opt = torch.optim.Adam(self.critics.parameters(), lr=config.lr)
        self.rnd_opt = torch.optim.Adam(self.rnd_predictor.parameters(), lr=config.lr)
        self.obs_norm = RunningNorm((obs_dim,))
        self.intr_norm = RunningNorm(())
        self.replay = Replay(config.replay_capacity, obs_dim, act_dim, config.nstep)
        self.env_steps = 0  # per environment
        self.updates = 0
        self._obs: list[np.ndarray] = []  # this episode's observations and actions so far
        self._actions: list[np.ndarray] = []
        self.last_intrinsic = 0.0

    # -- acting --------------------------------------------------------------------------
    def __call__(self, obs: np.ndarray, step: int) -> np.ndarray:
        if step == 0:
            self._obs, self._actions = [], []
        else:
            self.obs_norm.update(torch.from_numpy(obs))
        self._obs.append(obs.copy())
        n = self.cfg.nstep
        if len(self._obs) > n:  # the transition that started n steps ago is complete
            seq = np.stack(self._obs[-n:], axis=1)
            self.replay.add(self._obs[-n - 1], self._actions[-n], seq, n)
        if self.env_steps < self.cfg.seed_steps:
            action = self.rng.uniform(-1, 1, (len(obs), self.act_dim)).astype(np.float32)
        else:
            with torch.no_grad():
                mu = self.actor(torch.from_numpy(obs)).numpy()
            noise = self.rng.normal(0, self.cfg.stddev, mu.shape)
            action = np.clip(mu + noise, -1, 1).astype(np.float32)
            if self.env_steps % self.cfg.update_every == 0:
                for _ in range(self.cfg.updates_per_step):
                    self.update()
        self.env_steps += 1
        self._actions.append(action)
        return action

    def end_episodes(self, observation: np.ndarray, action: np.ndarray) -> None:
        """Store the transitions the episodes' end left short of n steps (the rollout's
        observation (N, T+1, d) and action (N, T, a) arrays)."""
        t_len = action.shape[1]
        self.replay.add_steps(observation, action, range(max(0, t_len - self.cfg.nstep), t_len))
        self._obs, self._actions = [], []

    # -- learning --------------------------------------------------------------------------
    def _normalise(self, obs: torch.Tensor) -> torch.Tensor:
        return ((obs - self.obs_norm.mean) / (self.obs_norm.var.sqrt() + 1e-8)).clamp(-5, 5)

    def _q(self, nets: nn.ModuleList, obs: torch.Tensor, action: torch.Tensor) -> torch.Tensor:
        x = torch.cat([obs, action], dim=-1)
        return torch.minimum(nets[0](x), nets[1](x)).squeeze(-1)

    def update(self) -> None:
        cfg = self.cfg
        obs, action, next_seq, n_valid = self.replay.sample(cfg.batch_size, self.rng)
        b, n, d = next_seq.shape
        valid = (torch.arange(n)[None] < n_valid[:, None]).float()
        # RND: the predictor learns the target on visited states; its error is the reward.
        flat = self._normalise(next_seq.reshape(b * n, d))
        error = (self.rnd_predictor(flat) - self.rnd_target(flat)).pow(2).mean(-1).view(b, n)
        self.rnd_opt.zero_grad(set_to_none=True)
        ((error * valid).sum() / valid.sum()).backward()
        self.rnd_opt.step()
        intrinsic = error.detach()
        self.intr_norm.update(intrinsic[:, :1])
        reward = intrinsic / (self.intr_norm.var.sqrt() + 1e-8)
        # n-step return, then bootstrap from the last real state (there are no terminals).
        ret = (reward * valid * cfg.discount ** torch.arange(n, dtype=torch.float32)).sum(-1)
        last = next_seq[torch.arange(b), n_valid - 1]
        with torch.no_grad():
            noise = torch.randn_like(action) * cfg.stddev
            noise = noise.clamp(-cfg.stddev_clip, cfg.stddev_clip)
            next_action = (self.actor(last) + noise).clamp(-1, 1)
            next_q = self._q(self.critic_targets, last, next_action)
            target = ret + cfg.discount ** n_valid.float() * next_q
        x = torch.cat([obs, action], dim=-1)
        q1, q2 = (c(x).squeeze(-1) for c in self.critics)
        critic_loss = F.mse_loss(q1, target) + F.mse_loss(q2, target)
        self.critic_opt.zero_grad(set_to_none=True)
        critic_loss.backward()
        self.critic_opt.step()
        # Actor: maximise the twin-minimum value of its own actions.
        actor_loss = -self._q(self.critics, obs, self.actor(obs)).mean()
        self.actor_opt.zero_grad(set_to_none=True)
        actor_loss.backward()
        self.actor_opt.step()
        with torch.no_grad():
            for p, tp in zip(
                self.critics.parameters(), self.critic_targets.parameters(), strict=True
            ):
                tp.lerp_(p, cfg.tau)
        self.updates += 1
        self.last_intrinsic = float(intrinsic[:, 0].mean())

    # -- checkpoint ------------------------------------------------------------------------
    def state(self) -> dict[str, Any]:
        return {
            "actor": self.actor.state_dict(),
            "critics": self.critics.state_dict(),
            "critic_targets": self.critic_targets.state_dict(),
            "rnd_target": self.rnd_target.state_dict(),
            "rnd_predictor": self.rnd_predictor.state_dict(),
            "actor_opt": self.actor_opt.state_dict(),
            "critic_opt": self.critic_opt.state_dict(),
            "rnd_opt": self.rnd_opt.state_dict(),
            "obs_norm": self.obs_norm.state(),
            "intr_norm": self.intr_norm.state(),
            "env_steps": self.env_steps,
            "updates": self.updates,
            "rng": self.rng.bit_generator.state,
            "torch_rng": torch.get_rng_state(),
        }

    def load(self, state: dict[str, Any]) -> None:
        for name in (
            "actor",
            "critics",
            "critic_targets",
            "rnd_target",
            "rnd_predictor",
            "actor_opt",
            "critic_opt",
            "rnd_opt",
        ):
            getattr(self, name).load_state_dict(state[name])
        self.obs_norm.load(state["obs_norm"])
        self.intr_norm.load(state["intr_norm"])
        self.env_steps, self.updates = int(state["env_steps"]), int(state["updates"])
        self.rng.bit_generator.state = state["rng"]
        torch.set_rng_state(state["torch_rng"])


class RNDPopulation:
    """Several independent RND explorers, each driving its own slice of the batch.

    One explorer's deterministic policy tends to settle into one region of the
    environment, so a population (with different seeds) reaches more of it for the same
    compute, much as distributed explorers with different noise levels do (Ape-X)."""

    def __init__(self, obs_dim: int, act_dim: int, config: RNDConfig, seed: int) -> None:
        if config.num_envs % config.agents:
            raise ValueError("num_envs must be a multiple of agents")
        self.cfg = config
        levels = np.linspace(config.stddev, config.stddev_max, config.agents)
        self.agents = [
            RNDExplorer(obs_dim, act_dim, replace(config, stddev=float(s)), seed * 1_000 + k)
            for k, s in enumerate(levels)
        ]

    def _slices(self, n: int) -> list[slice]:
        per = -(-n // len(self.agents))  # the last batch of a collection may be smaller
        return [slice(k * per, min(n, (k + 1) * per)) for k in range(len(self.agents))]

    def __call__(self, obs: np.ndarray, step: int) -> np.ndarray:
        parts = [
            a(obs[s], step)
            for a, s in zip(self.agents, self._slices(len(obs)), strict=True)
            if s.start < s.stop
        ]
        return np.concatenate(parts)

    def end_episodes(self, observation: np.ndarray, action: np.ndarray) -> None:
        for agent, s in zip(self.agents, self._slices(len(observation)), strict=True):
            if s.start < s.stop:
                agent.end_episodes(observation[s], action[s])

    @property
    def last_intrinsic(self) -> float:
        return float(np.mean([a.last_intrinsic for a in self.agents]))

    def state(self) -> dict[str, Any]:
        return {"agents": [a.state() for a in self.agents]}

    def load(self, state: dict[str, Any]) -> None:
        for agent, s in zip(self.agents, state["agents"], strict=True):
            agent.load(s)
