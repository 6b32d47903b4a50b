"""The batched rollout engine: N environments in lockstep, one policy call per step.

Data collection, experts and evaluation all roll out through here. A policy is any
callable `policy(obs, step) -> actions` on a batch: `obs` is (N, obs_dim) float32,
`step` the number of steps already taken in the episode (0 for the first action; what
time-indexed policies such as goal tracking need), actions (N, act_dim) in [-1, 1].
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from tqdm.auto import tqdm

from fbil.envs.env import FbilEnv, stack_quantities
from fbil.envs.hooks import Policy
from fbil.envs.registry import get_domain, get_task
from fbil.errors import FbilError

__all__ = ["BatchedEnv", "Episodes", "Policy", "RandomPolicy", "rollout"]


@dataclass
class Episodes:
    """N episodes of T steps. Index t of `action`/`reward` is the step from
    `observation[:, t]` to `observation[:, t + 1]`; `physics[:, t]` is the state behind
    `observation[:, t]` (so `physics[:, t + 1]` goes with `action[:, t]` for relabeling)."""

    domain: str
    task: str | None  # None: reward-free
    seeds: list[int]
    observation: np.ndarray  # (N, T+1, obs_dim) float32
    action: np.ndarray  # (N, T, act_dim) float32
    reward: np.ndarray  # (N, T) float64
    physics: np.ndarray  # (N, T+1, physics_dim) float64

    @property
    def returns(self) -> np.ndarray:
        return np.asarray(self.reward.sum(axis=1))

    def __len__(self) -> int:
        return int(self.observation.shape[0])


class RandomPolicy:
    """Uniform actions in [-1, 1]^act_dim from its own seeded RNG."""

    def __init__(self, act_dim: int, seed: int = 0) -> None:
        self.act_dim = act_dim
        self.rng = np.random.default_rng(seed)

    def __call__(self, obs: np.ndarray, step: int) -> np.ndarray:
        return self.rng.uniform(-1.0, 1.0, size=(obs.shape[0], self.act_dim)).astype(np.float32)


class BatchedEnv:
    """N copies of one task's environment, stepped together."""

    def __init__(self, domain: str, task: str | None, n: int) -> None:
        """`task=None` rolls out reward-free (rewards are all zero), e.g. for exploration."""
        if n < 1:
            raise FbilError(f"need at least one environment, got n={n}")
        self.spec = get_domain(domain)
        self.task_spec = get_task(domain, task) if task is not None else None
        self.domain, self.task = domain, task
        any_task = task if task is not None else self.spec.task_names[0]
        self.envs = [FbilEnv(domain, any_task) for _ in range(n)]

    def rollout(
        self,
        policy: Policy,
        seeds: Sequence[int],
        steps: int | None = None,
        start_states: np.ndarray | None = None,
        progress: bool = False,
    ) -> Episodes:
        """One episode per environment, reset with `seeds[i]` (optionally then moved to
        `start_states[i]`, a physics state), for `steps` steps (default: the full 1000)."""
        n, spec = len(self.envs), self.spec
        if len(seeds) != n:
            raise FbilError(f"need one seed per environment: {n} environments, {len(seeds)} seeds")
        steps = spec.episode_length if steps is None else steps
        if not 1 <= steps <= spec.episode_length:
            raise FbilError(f"steps must be in [1, {spec.episode_length}], got {steps}")
        obs = np.empty((n, steps + 1, spec.obs_dim), np.float32)
        act = np.empty((n, steps, spec.act_dim), np.float32)
        rew = np.empty((n, steps), np.float64)
        phys = np.empty((n, steps + 1, spec.physics_dim), np.float64)
        for i, (env, seed) in enumerate(zip(self.envs, seeds, strict=True)):
            obs[i, 0], info = env.reset(seed=int(seed))
            if start_states is not None:
                obs[i, 0] = env.set_physics_state(start_states[i])
                info["physics"] = env.physics.get_state()
            phys[i, 0] = info["physics"]
        desc = f"{self.domain}/{self.task or 'reward-free'}"
        for t in tqdm(range(steps), disable=not progress, desc=desc, leave=False):
            actions = self._check(policy(obs[:, t], t), n)
            rows = []
            for i, env in enumerate(self.envs):
                env.advance(actions[i])
                obs[i, t + 1], phys[i, t + 1] = env.observe(), env.physics.get_state()
                if self.task_spec is not None:
                    rows.append(spec.read_quantities(env.physics))
            # One vectorised reward call for the whole batch.
            if self.task_spec is not None:
                rew[:, t] = self.task_spec.reward(stack_quantities(spec, rows))
            else:
                rew[:, t] = 0.0
            act[:, t] = np.clip(actions, -1.0, 1.0)
        return Episodes(self.domain, self.task, [int(s) for s in seeds], obs, act, rew, phys)

    def _check(self, actions: np.ndarray, n: int) -> np.ndarray:
        a = np.asarray(actions, dtype=np.float32)
        if a.shape != (n, self.spec.act_dim):
            raise FbilError(
                f"policy returned actions of shape {a.shape}, expected ({n}, {self.spec.act_dim})"
            )
        if not np.all(np.isfinite(a)):
            raise FbilError("policy returned NaN or inf actions")
        return a


def rollout(
    domain: str,
    task: str,
    policy: Policy,
    seeds: Sequence[int],
    steps: int | None = None,
    progress: bool = False,
) -> Episodes:
    """Convenience: build `len(seeds)` environments and roll out one episode in each."""
    return BatchedEnv(domain, task, len(seeds)).rollout(policy, seeds, steps, progress=progress)
