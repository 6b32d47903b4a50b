"""OTR (Luo et al. 2023, "Optimal Transport for Offline Imitation Learning"), with TD3 as
the paper's App. B (OTR_TD3): every unsupervised episode gets per-step rewards from an
entropic optimal transport between its states and the expert demonstration's, then
offline TD3 learns from the relabeled dataset.

For an episode with next states x_1..x_n and a demo with states y_1..y_m (both uniform
weights), Sinkhorn (POT's `ot.sinkhorn`, entropic regularisation `epsilon`, OTR's 100
iterations) gives the plan P for the cosine cost C_ij = 1 - cos(x_i, y_j). Step i's cost
is the mean cost of its mass, c_i = n * sum_j P_ij C_ij in [0, 2], and its reward OTR's
exponential squashing r_i = alpha * exp(-beta * c_i / d) (d: the state size; OTR's
alpha * exp(beta * T / d * (-sum_j P_ij C_ij)) with T = n). With several demos, each
episode takes the rewards of the demo that rewards it most (OTR's top-1 aggregation).
Oversampled windows (short copies of stretches of episodes) take the rewards of the
transitions they copy; `return_span` optionally rescales rewards as the reference code does.
"""

from __future__ import annotations

import warnings
from collections import defaultdict
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import ot
import torch

from fbil.baselines.common import TrainedPolicy, Transitions, trained_imitator
from fbil.baselines.offline_td3 import OfflineTD3Config, agent_state, train_offline_td3
from fbil.data.oversample import copy_sources
from fbil.imitation.demos import Demos
from fbil.imitators.base import FitContext
from fbil.imitators.budgets import Budgets


@dataclass(frozen=True)
class OTRConfig:
    td3: OfflineTD3Config = field(default_factory=OfflineTD3Config)
    epsilon: float = 0.01  # Sinkhorn's entropic regularisation (OTR: 0.01)
    iterations: int = 100  # Sinkhorn iterations (OTR: 100, threshold 1e-9)
    alpha: float = 5.0  # OTR's exponential squashing r = alpha * exp(-beta * c / d)
    beta: float = 5.0
    batch_episodes: int = 64  # episodes of one length whose costs are computed together
    return_span: float | None = None  # rewards x span / (max - min episode return) (cpu: 1000)


BUDGETS = Budgets(
    cpu=OTRConfig(return_span=1000.0),  # the reference's rescaling (session 30)
    smoke=OTRConfig(OfflineTD3Config(steps=20, hidden=32, batch_size=64), iterations=20),
)


def cosine_cost(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """C[..., i, j] = 1 - cos(x_i, y_j) for x (..., n, d) and y (m, d) (OTR's cost)."""

    def unit(v: np.ndarray) -> np.ndarray:
        return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-8)

    return 1.0 - unit(x) @ unit(y).T


def sinkhorn_plan(cost: np.ndarray, epsilon: float, iterations: int) -> np.ndarray:
    """The entropic OT plan between uniform weights, by POT's Sinkhorn-Knopp (float64;
    its log-domain version if the plain one under- or overflows)."""
    n, m = cost.shape
    a, b = np.full(n, 1.0 / n), np.full(m, 1.0 / m)
    with warnings.catch_warnings():  # a fixed number of iterations, as OTR
        warnings.filterwarnings("ignore", message="Sinkhorn did not converge")
        warnings.filterwarnings("ignore", message="Numerical errors")
        plan = ot.sinkhorn(a, b, cost, epsilon, numItermax=iterations, stopThr=1e-9)
        if not np.isfinite(plan).all() or abs(plan.sum() - 1.0) > 1e-3:
            plan = ot.sinkhorn(
                a, b, cost, epsilon, method="sinkhorn_log", numItermax=iterations, stopThr=1e-9
            )
    return np.asarray(plan)


def step_costs(cost: np.ndarray, cfg: OTRConfig) -> np.ndarray:
    """c_i = n * sum_j P_ij C_ij for a cost matrix C (n, m): the mean transport cost of
    each step's mass, in [0, max C]."""
    return len(cost) * (sinkhorn_plan(cost, cfg.epsilon, cfg.iterations) * cost).sum(1)


def squash(costs: np.ndarray, obs_dim: int, cfg: OTRConfig) -> np.ndarray:
    return cfg.alpha * np.exp(-cfg.beta * costs / obs_dim)


def otr_rewards(episode: np.ndarray, demo: np.ndarray, cfg: OTRConfig) -> np.ndarray:
    """Per-step rewards of one episode's states (n, d) against one demo's (m, d)."""
    cost = cosine_cost(episode.astype(np.float64), demo.astype(np.float64))
    return squash(step_costs(cost, cfg), episode.shape[1], cfg)


def episode_rewards(
    episodes: list[np.ndarray], demos: list[np.ndarray], cfg: OTRConfig
) -> list[np.ndarray]:
    """Per-step OTR rewards of each episode (states (n_e, d)) against its best demo.
    Episodes of one length go in batches: one matrix product gives all their costs to a
    demo, then Sinkhorn runs per episode (POT's batched solver `ot.batch` was 6x slower
    per episode on one CPU core at n = m = 1000)."""
    out: list[np.ndarray] = [np.empty(0)] * len(episodes)
    by_length: dict[int, list[int]] = defaultdict(list)
    for e, states in enumerate(episodes):
        by_length[len(states)].append(e)
    for members in by_length.values():
        for start in range(0, len(members), cfg.batch_episodes):
            batch = members[start : start + cfg.batch_episodes]
            x = np.stack([episodes[e] for e in batch]).astype(np.float64)
            best = np.full((len(batch), x.shape[1]), -np.inf)
            for demo in demos:
                costs = cosine_cost(x, demo.astype(np.float64))
                for i, cost in enumerate(costs):
                    r = squash(step_costs(cost, cfg), x.shape[2], cfg)
                    if r.sum() > best[i].sum():
                        best[i] = r
            for i, e in enumerate(batch):
                out[e] = best[i]
    return out


def return_scale(per_episode: list[np.ndarray], span: float | None) -> float:
    """The factor that stretches the episodes' returns to `span` between the lowest and the
    highest (the OTR reference code's rescaling, IQL's for locomotion: span 1000); 1 when
    `span` is None or all returns are equal."""
    if span is None:
        return 1.0
    returns = np.array([r.sum() for r in per_episode])
    width = float(returns.max() - returns.min()) if len(returns) else 0.0
    return span / width if width > 0 else 1.0


def relabel(dataset: Any, demos: Demos, cfg: OTRConfig) -> torch.Tensor:
    """OTR rewards of every dataset transition, in `next_index` order: episode e's
    transitions are its rows after the reset row, rewarded by their next states. An
    oversampled window (a copy of a stretch of a longer episode, `copy_sources`) is not an
    episode of its own: transported alone against the whole demo it would be paid as a
    poor match; its transitions take the rewards of the ones they copy."""
    sources = copy_sources(dataset)
    whole = np.flatnonzero(sources < 0)
    starts, ends = dataset.episode_start, dataset.episode_end
    episodes = [dataset.observation[starts[e] + 1 : ends[e] + 1] for e in whole]
    demo_states = [np.asarray(t.observation, np.float32)[1:] for t in demos.trajectories]
    per_episode = episode_rewards(episodes, demo_states, cfg)
    scale = return_scale(per_episode, cfg.return_span)
    by_row = np.zeros(len(dataset.observation))  # the reward of the transition into a row
    for e, rewards in zip(whole, per_episode, strict=True):
        by_row[starts[e] + 1 : ends[e] + 1] = rewards * scale
    copies = np.flatnonzero(sources >= 0)
    for e in copies[np.argsort(starts[copies] - ends[copies], kind="stable")]:  # longest first
        n = ends[e] - starts[e]
        by_row[starts[e] + 1 : ends[e] + 1] = by_row[sources[e] + 1 : sources[e] + 1 + n]
    return torch.from_numpy(by_row[dataset.next_index].astype(np.float32))


def fit(demos: Demos, context: FitContext) -> TrainedPolicy:
    cfg = BUDGETS[context.budget]
    rewards = relabel(context.dataset, demos, cfg)

    def label(batch: Transitions) -> torch.Tensor:
        assert batch.index is not None  # dataset rows only: no expert rows are mixed in
        return rewards[batch.index]

    agent, info = train_offline_td3(
        context.dataset,
        label,
        cfg.td3,
        context.seed,
        checkpoint=context.checkpoint,
        reward_range=(float(rewards.min()), float(rewards.max())),
    )
    info["otr_reward_mean"] = round(float(rewards.mean()), 5)
    info["otr_reward_max"] = round(float(rewards.max()), 5)
    return TrainedPolicy("otr", agent.act, agent_state(agent), info, agent.cfg.precision)


IMITATOR = trained_imitator(
    "otr", "reward (optimal transport)", fit, BUDGETS, needs_actions=False, needs_dataset=True
)
