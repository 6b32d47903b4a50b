"""BC: behaviour cloning on the demonstrations' (s, a) pairs, with no other data.

An MLP (App. D: two hidden layers, layer norm and tanh on the first) from standardised
states to actions, trained by Adam on minibatches of demo rows, with either the squared
error of its tanh output ("mse") or the Gaussian log-likelihood of the expert actions
("gaussian": a tanh mean and a state-dependent log-std; acting plays the mean)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import torch

from fbil.agents.td3 import _mlp, run_mlp
from fbil.baselines.common import TrainedPolicy, demo_transitions, standardiser, trained_imitator
from fbil.errors import FbilError
from fbil.imitation.demos import Demos
from fbil.imitators.base import FitContext
from fbil.imitators.budgets import Budgets

LOG_STD = (-5.0, 2.0)  # the Gaussian's log-std range


@dataclass(frozen=True)
class BCConfig:
    steps: int = 20_000
    hidden: int = 256  # paper: 1024
    batch_size: int = 512
    lr: float = 1e-4
    loss: str = "mse"  # or "gaussian"

    def __post_init__(self) -> None:
        if self.loss not in ("mse", "gaussian"):
            raise FbilError(f"unknown BC loss {self.loss!r}; valid: mse, gaussian")


BUDGETS = Budgets(
    cpu=BCConfig(),
    smoke=BCConfig(steps=50, hidden=32, batch_size=64),
)


def gaussian_log_prob(out: torch.Tensor, action: torch.Tensor) -> torch.Tensor:
    """Per-dimension log-likelihoods (B, act_dim) of `action` under the Gaussian of network
    outputs `out`: a tanh mean and a log-std clamped to `LOG_STD`."""
    act_dim = action.shape[1]
    log_std = out[:, act_dim:].clamp(*LOG_STD)
    z = (action - torch.tanh(out[:, :act_dim])) / log_std.exp()
    return -(0.5 * z**2 + log_std + 0.5 * math.log(2 * math.pi))


def bc_loss(out: torch.Tensor, action: torch.Tensor, loss: str) -> torch.Tensor:
    """The loss of network outputs `out` on expert actions (mean over rows)."""
    if loss == "mse":
        return ((torch.tanh(out[:, : action.shape[1]]) - action) ** 2).sum(-1).mean()
    return -gaussian_log_prob(out, action).sum(-1).mean()


def mean_action_policy(
    method: str,
    net: torch.nn.Module,
    stats: torch.Tensor,
    act_dim: int,
    info: dict[str, float],
    precision: str = "fp32",
) -> TrainedPolicy:
    """A policy that plays the tanh of the first `act_dim` outputs of `net` (run as
    `run_mlp` runs it) on states standardised by `stats` (mean, std)."""
    net.requires_grad_(False)

    def act(o: np.ndarray) -> np.ndarray:
        out = run_mlp(net, (torch.as_tensor(o) - stats[0]) / stats[1], precision)
        return torch.tanh(out[:, :act_dim]).numpy()

    state = {"net": net.state_dict(), "obs_stats": stats}
    return TrainedPolicy(method, act, state, info, precision)


def train_bc(obs: torch.Tensor, action: torch.Tensor, cfg: BCConfig, seed: int) -> TrainedPolicy:
    """An MLP fitted to (obs, action) rows; the policy plays its (mean) action."""
    torch.manual_seed(seed)
    gen = torch.Generator().manual_seed(seed)
    act_dim = action.shape[1]
    stats = standardiser(obs, 1e-2)  # a single demo has near-constant dimensions
    outputs = act_dim * (2 if cfg.loss == "gaussian" else 1)
    net = _mlp(obs.shape[1], cfg.hidden, outputs)
    opt = torch.optim.Adam(net.parameters(), lr=cfg.lr)
    x = (obs - stats[0]) / stats[1]
    loss = torch.zeros(())
    for _ in range(cfg.steps):
        rows = torch.randint(0, len(x), (cfg.batch_size,), generator=gen)
        loss = bc_loss(net(x[rows]), action[rows], cfg.loss)
        opt.zero_grad(set_to_none=True)
        loss.backward()
        opt.step()
    info = {"loss_last": round(float(loss.detach()), 6)}
    return mean_action_policy("bc", net, stats, act_dim, info)


def fit(demos: Demos, context: FitContext) -> TrainedPolicy:
    rows = demo_transitions(demos)
    assert rows.action is not None  # checked by the imitator (needs_actions)
    return train_bc(rows.obs, rows.action, BUDGETS[context.budget], context.seed)


IMITATOR = trained_imitator(
    "bc", "behavioral cloning", fit, BUDGETS, needs_actions=True, needs_dataset=False
)
