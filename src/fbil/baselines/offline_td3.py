"""Offline TD3 on the unsupervised dataset (optionally mixed with the expert transitions),
relabeled by an imitation reward: the RL half of TD3IL and the ORIL variants.

Each minibatch holds `batch_size` rows: expert rows at a fixed ratio (TD3IL, paper App. B),
or drawn uniformly from the union of both sets (`expert_ratio=None`), or none (no expert
set); a `Labeler` gives every row its reward, then one `fbil.agents.td3.TD3` update."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Literal

import torch

from fbil.agents.td3 import TD3, TD3Config
from fbil.baselines.common import (
    Transitions,
    dataset_rows,
    paper_gamma,
    value_bounds,
    value_check,
)
from fbil.checkpoint import FitCheckpoint
from fbil.errors import FbilError

Labeler = Callable[[Transitions], torch.Tensor]  # a minibatch -> its rewards (B,)


@dataclass(frozen=True)
class OfflineTD3Config:
    """Table 2's settings for the TD3 of the IL baselines, with the networks' width and the
    number of gradient steps shrunk for CPUs (paper: 1024 units)."""

    steps: int = 50_000
    hidden: int = 256
    batch_size: int = 512
    lr: float = 1e-4
    tau: float = 0.01  # target momentum 0.99
    policy_noise: float = 0.2
    noise_clip: float = 0.3
    # Critic updates per actor and target update: 2 is Fujimoto's TD3 (the targets then
    # move at tau per two critic steps); 1 updates both every step, as Meta's DDPG-style
    # agent does, whose settings Table 2 lists (docs/td3-reference-audit.md).
    policy_delay: int = 2
    # bf16 autocast on the hidden layers (last layers, losses and Adam in fp32): 2.08x less
    # CPU time per update at the maze size (15.8 against 7.6 ms, 1 thread); see docs.
    precision: Literal["fp32", "bf16"] = "bf16"
    # TD3+BC's alpha (the actor loss -lambda Q + |pi(s) - a|^2, lambda = alpha / mean |Q|),
    # as the ORIL and OTR reference code trains its policy; None: plain TD3, the paper's
    # "offline RL agent" (App. B). A diagnostic option, off in every budget.
    bc_alpha: float | None = None
    # The actor's objective, TD3's "q1" or the reference agent's "min_noisy" (see TD3Config);
    # a diagnostic option, "q1" in every budget.
    actor_q: Literal["q1", "min_noisy"] = "q1"
    # Standardise the networks' inputs by the dataset's mean and std (TD3+BC); False feeds
    # raw states, as Meta's agent does (its first layer's layer norm + tanh only). Diagnostic.
    standardize: bool = True
    # The TD target's clamp (TD3Config's): [0, 1/(1 - gamma)] bounds every value of a
    # reward in [0, 1]. Diagnostic, off in every budget (cheetah's oracle diverged without).
    target_min: float | None = None
    target_max: float | None = None
    # Clamp the TD target to the values the method's rewards allow (`value_bounds` of the
    # reward range each method declares: td3il [0, 1], ORIL (0, log 2), OTR its table's);
    # False: no clamp. Cheetah's critics diverge without it (docs/cheetah.md, session 53).
    clamp_values: bool = False

    def __post_init__(self) -> None:
        if self.clamp_values and (self.target_min is not None or self.target_max is not None):
            raise FbilError(
                "clamp_values derives target_min/target_max from the reward range; "
                "set one or the other, not both"
            )

    def td3(self, domain: str, reward_range: tuple[float, float] | None = None) -> TD3Config:
        """The agent's settings; `reward_range` (the method's) sets the clamp when
        `clamp_values` is on."""
        gamma, lo, hi = paper_gamma(domain), self.target_min, self.target_max
        if self.clamp_values:
            if reward_range is None:
                raise FbilError("clamp_values needs the method's reward range; this one has none")
            lo, hi = value_bounds(reward_range, gamma)
        return TD3Config(
            hidden=self.hidden,
            batch_size=self.batch_size,
            lr=self.lr,
            gamma=gamma,
            tau=self.tau,
            policy_noise=self.policy_noise,
            noise_clip=self.noise_clip,
            policy_delay=self.policy_delay,
            precision=self.precision,
            bc_alpha=self.bc_alpha,
            actor_q=self.actor_q,
            target_min=lo,
            target_max=hi,
        )


class MixedSampler:
    """Minibatches of dataset rows and expert rows (see the module's docstring)."""

    def __init__(
        self,
        dataset: Any,
        expert: Transitions | None,
        batch_size: int,
        expert_ratio: float | None,
        gen: torch.Generator,
    ) -> None:
        if expert is not None and expert.action is None:
            raise FbilError("expert rows for TD3 need actions")
        if expert_ratio is not None and not 0.0 <= expert_ratio < 1.0:
            raise FbilError(f"expert_ratio must be in [0, 1), got {expert_ratio}")
        self.dataset, self.expert, self.gen = dataset, expert, gen
        self.batch_size, self.ratio = batch_size, expert_ratio
        self.n_data = int(dataset.num_transitions)

    def expert_count(self) -> int:
        """Expert rows in the next minibatch."""
        if self.expert is None:
            return 0
        if self.ratio is not None:  # fixed: at least one row whenever the ratio is > 0
            return max(1, round(self.ratio * self.batch_size)) if self.ratio > 0 else 0
        share = len(self.expert) / (len(self.expert) + self.n_data)
        draw = torch.rand(self.batch_size, generator=self.gen) < share
        return int(draw.sum())

    def __call__(self) -> Transitions:
        n_expert = self.expert_count()
        rows = torch.randint(0, self.n_data, (self.batch_size - n_expert,), generator=self.gen)
        part = dataset_rows(self.dataset, rows)
        if not n_expert:
            return part
        e = self.expert
        assert e is not None and e.action is not None and part.action is not None
        pick = torch.randint(0, len(e), (n_expert,), generator=self.gen)
        return Transitions(
            torch.cat([part.obs, e.obs[pick]]),
            torch.cat([part.action, e.action[pick]]),
            torch.cat([part.next_obs, e.next_obs[pick]]),
            torch.cat([part.discount, e.discount[pick]]),
            torch.cat([part.expert, e.expert[pick]]),
        )


def train_offline_td3(
    dataset: Any,
    label: Labeler,
    config: OfflineTD3Config,
    seed: int,
    expert: Transitions | None = None,
    expert_ratio: float | None = None,
    on_step: Callable[[int, TD3], None] | None = None,
    checkpoint: FitCheckpoint | None = None,
    reward_range: tuple[float, float] | None = None,
) -> tuple[TD3, dict[str, float]]:
    """TD3 trained for `config.steps` updates on relabeled minibatches; the agent and the
    last update's numbers (critic loss, mean Q, mean reward). `on_step(t, agent)` runs
    after update t (1-based): a diagnostic's budget curve within one run. `checkpoint`:
    the loop resumes from it and saves to it (the agent's state holds the sampler's RNG,
    so a resumed run is the same run). `reward_range`: the bounds of `label`'s rewards
    (for `config.clamp_values`)."""
    spec = config.td3(dataset.domain, reward_range)
    agent = TD3(dataset.observation.shape[1], dataset.action.shape[1], spec, seed)
    if config.standardize:
        agent.set_obs_stats(dataset.observation)
    sample = MixedSampler(dataset, expert, spec.batch_size, expert_ratio, agent.gen)
    last: dict[str, float] = {}
    first = 1
    if checkpoint is not None and (saved := checkpoint.resume("td3")) is not None:
        agent.load(saved[1])
        first, last = saved[0] + 1, saved[2]
    for t in range(first, config.steps + 1):
        batch = sample()
        with torch.no_grad():
            reward = label(batch).float()
        assert batch.action is not None
        metrics = agent.update(batch.obs, batch.action, reward, batch.next_obs, batch.discount)
        last = {**metrics, "reward_mean": float(reward.mean())}
        if checkpoint is not None:
            checkpoint.tick("td3", t, config.steps, agent.state, last)
        if on_step is not None:
            on_step(t, agent)
    info = {k: round(v, 5) for k, v in last.items()}
    if reward_range is not None:
        info = value_check(info, value_bounds(reward_range, spec.gamma)[1])
    return agent, info


def agent_state(agent: TD3) -> dict[str, Any]:
    """What an imitation policy file keeps of a TD3 agent: its actor and input statistics."""
    return {"actor": agent.actor.state_dict(), "obs_stats": agent.obs_stats}
