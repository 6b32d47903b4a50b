"""What the baselines share: the paper's per-domain settings (App. D, Table 2), transition
tensors from demonstrations and from the unsupervised dataset, and a trained network as an
imitation policy."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch

from fbil.agents.td3 import _mlp
from fbil.checkpoint import load_state, save_state
from fbil.errors import FbilError
from fbil.imitation.demos import Demos
from fbil.imitators.base import FitContext, Imitator, Policy
from fbil.imitators.budgets import Budgets

# Table 2: the discount of the IL baselines (0.98 in locomotion) and ORIL's gradient
# penalty weight, per domain.
PAPER_GAMMA = {"point_mass_maze": 0.99, "walker": 0.98, "cheetah": 0.98, "quadruped": 0.98}
PAPER_GRADIENT_PENALTY = {"point_mass_maze": 10.0, "walker": 2.0, "cheetah": 2.0, "quadruped": 10.0}


def paper_gamma(domain: str) -> float:
    return PAPER_GAMMA.get(domain, 0.98)


def value_bounds(
    reward_range: tuple[float, float], gamma: float, bonus: float = 0.0
) -> tuple[float, float]:
    """The interval that holds every discounted return sum_t gamma^t (r_t + bonus_t) of
    rewards in `reward_range` and per-step bonuses at most `bonus` (from above only: SAC's
    entropy term), episodes of any length included (so 0 lies inside)."""
    lo, hi = reward_range
    if not lo <= hi:
        raise FbilError(f"reward range ({lo}, {hi}): the low end must not exceed the high end")
    return min(0.0, lo) / (1 - gamma), max(0.0, hi + bonus) / (1 - gamma)


def value_check(info: dict[str, float], bound: float) -> dict[str, float]:
    """`info` (a learner's last update: its critics' mean Q on the minibatch, "q") with
    `q_bound`, the largest value the method's rewards allow, and `q_diverged`: 1 when the
    mean Q is above twice that bound, a critic that has run away (cheetah's unclamped
    oracles: 1 694 against 50), else 0."""
    out = {**info, "q_bound": round(bound, 3)}
    if "q" in info:
        out["q_diverged"] = float(info["q"] > 2 * bound)
    return out


@dataclass
class Transitions:
    """Rows (s, a, s', discount); `expert` marks rows from the demonstrations."""

    obs: torch.Tensor
    action: torch.Tensor | None
    next_obs: torch.Tensor
    discount: torch.Tensor
    expert: torch.Tensor  # bool
    # Dataset rows only: each row's transition number (into `next_index`), for rewards
    # labeled per transition beforehand (OTR); None for rows mixed with expert rows.
    index: torch.Tensor | None = None

    def __len__(self) -> int:
        return len(self.obs)

    def select(self, rows: torch.Tensor) -> Transitions:
        """The rows `rows` (indices or a mask)."""
        action = None if self.action is None else self.action[rows]
        index = None if self.index is None else self.index[rows]
        return Transitions(
            self.obs[rows],
            action,
            self.next_obs[rows],
            self.discount[rows],
            self.expert[rows],
            index,
        )


def demo_transitions(demos: Demos) -> Transitions:
    """All (s_t, a_t, s_{t+1}) of the demonstrations (no actions for action-free demos)."""
    obs = [torch.as_tensor(np.asarray(t.observation, np.float32)) for t in demos.trajectories]
    action = (
        torch.cat([torch.as_tensor(np.asarray(t.action, np.float32)) for t in demos.trajectories])
        if demos.has_actions
        else None
    )
    cur = torch.cat([o[:-1] for o in obs])
    return Transitions(
        cur,
        action,
        torch.cat([o[1:] for o in obs]),
        torch.ones(len(cur)),
        torch.ones(len(cur), dtype=torch.bool),
    )


def dataset_rows(dataset: Any, rows: torch.Tensor) -> Transitions:
    """Transitions `rows` (indices into the dataset's transitions) of an unsupervised
    dataset, as views of its arrays: transition j is (obs[j-1], action[j], obs[j])."""
    j = torch.from_numpy(dataset.next_index)[rows]
    observation = torch.from_numpy(dataset.observation)
    return Transitions(
        observation[j - 1],
        torch.from_numpy(dataset.action)[j],
        observation[j],
        torch.from_numpy(dataset.discount)[j],
        torch.zeros(len(rows), dtype=torch.bool),
        rows,
    )


def standardiser(observations: np.ndarray | torch.Tensor, floor: float) -> torch.Tensor:
    """(mean, std) of observations, std at least `floor`: a (2, obs_dim) tensor."""
    obs = torch.as_tensor(observations, dtype=torch.float64)
    return torch.stack([obs.mean(0), obs.std(0).clamp_min(floor)]).float()


class TrainedPolicy:
    """A network trained for one imitation task, as a batched imitation policy."""

    suffix = ".safetensors"

    def __init__(
        self,
        method: str,
        act_fn: Callable[[np.ndarray], np.ndarray],
        state: dict[str, Any],
        info: dict[str, float],
        precision: str = "fp32",
    ) -> None:
        self.method, self.act_fn, self.state, self.info = method, act_fn, state, dict(info)
        self.precision = precision  # how the network ran in training and acts (`run_mlp`)

    @torch.no_grad()
    def act(self, obs: np.ndarray, step: int | None = None) -> np.ndarray:
        actions = self.act_fn(np.asarray(obs, np.float32))
        return np.clip(actions, -1.0, 1.0).astype(np.float32)

    __call__ = act

    def reset(self) -> None:
        pass  # Markovian: no counter

    def describe(self) -> dict[str, Any]:
        return dict(self.info)

    def save(self, path: str | Path) -> Path:
        """The network, its input statistics and what `load_trained_policy` needs to act
        as this policy does (method, precision, action size)."""
        obs_dim = int(self.state["obs_stats"].shape[1])
        act_dim = int(self.act(np.zeros((1, obs_dim), np.float32)).shape[1])
        meta = {"method": self.method, "info": self.info, "precision": self.precision}
        return save_state(path, {**meta, "act_dim": act_dim, **self.state})


_NETS = ("actor", "net")  # where a policy file keeps its network: TD3 / SAC, or BC's


def load_trained_policy(path: str | Path) -> TrainedPolicy:
    """A baseline's policy file (`TrainedPolicy.save`) as a policy that acts as it did:
    tanh of the network's first act_dim outputs on standardised states."""
    state = load_state(path)
    found = [k for k in _NETS if isinstance(state.get(k), dict)]
    if not found or "obs_stats" not in state or "act_dim" not in state:
        raise FbilError(
            f"{path}: not a baseline policy file (expected a network, obs_stats and act_dim, "
            "written by `fbil imitate --out`); re-run `fbil imitate` to write it"
        )
    weights = dict(state[found[0]])
    if all(k.startswith("0.") for k in weights):  # TD3's actor: Sequential(_mlp, Tanh)
        weights = {k[2:]: v for k, v in weights.items()}
    try:
        hidden, inp = weights["0.weight"].shape
        net = _mlp(int(inp), int(hidden), int(weights["5.weight"].shape[0]))
        net.load_state_dict(weights)
    except (KeyError, RuntimeError, ValueError) as exc:
        raise FbilError(f"{path}: the network does not match App. D's MLP ({exc})") from None
    from fbil.baselines.bc import mean_action_policy  # bc builds on this module

    method, info = str(state.get("method", "?")), state.get("info", {})
    precision = str(state.get("precision", "fp32"))
    stats = state["obs_stats"].float()
    return mean_action_policy(method, net, stats, int(state["act_dim"]), info, precision)


def trained_imitator(
    name: str,
    principle: str,
    fit: Callable[[Demos, FitContext], Policy],
    budgets: Budgets,
    needs_actions: bool,
    needs_dataset: bool,
) -> Imitator:
    """An offline-IL imitator with named budgets (`fit` reads its configuration as
    `budgets[context.budget]`, which also resolves scaled specs such as 'cpu@0.5'); its
    results lines record the budget's spec and its whole resolved configuration."""
    assert isinstance(budgets, Budgets), "a baseline's budgets are a fbil.imitators.Budgets"

    def settings(context: FitContext) -> dict[str, Any]:
        return {"budget": context.budget, "config": asdict(budgets[context.budget])}

    return Imitator(
        name,
        "offline-il",
        principle,
        fit,
        needs_actions=needs_actions,
        needs_dataset=needs_dataset,
        budgets=tuple(budgets),
        settings=settings,
    )
