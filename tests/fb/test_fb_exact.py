"""FB training against the closed-form successor measure of a finite MDP.

The trainer's own update (sampling, FB loss, orthonormality, targets) runs with tabular
networks swapped in: B(s) = B[s], F^k(s, a, z) = F^k[s, a] and a fixed deterministic
policy pi (the actor ignores z, and its one parameter gets no gradient), so that every z
names the same pi and the FB loss has one fixed point. Data: episodes of a uniformly
random behaviour policy beta. With rho the distribution of the sampled next states and
m(s, a, s') := F(s, a)^T B(s') rho(s'), the n-step FB loss is minimised where

    m = A + gamma^n C Pi m,   so   m = (I - gamma^n C Pi)^-1 A,

with, over the sampled windows (s_t, a_t, s_{t+1}, ..., s_{t+n}) that start at (s, a),
A(s, a) = E[sum_{k<n} gamma^k e_{s_{t+k+1}}], C(s, a) = E[e_{s_{t+n}}], and Pi the
policy's (S, S A) selection matrix. For n = 1 (the paper's loss) A = C = P (the data's
transition kernel) and m is M^pi, the successor measure of pi. For n > 1 the fixed point
is the successor measure of "follow beta for n - 1 steps, then pi", not M^pi: the n-step
target is off-policy biased towards the data's behaviour; the test states both.
"""

from __future__ import annotations

import copy
from pathlib import Path

import numpy as np
import pytest
import torch
from torch import nn

from fbil.data.dataset import Dataset
from fbil.fb.config import FBModelConfig, FBTrainConfig
from fbil.fb.train import FBTrainer

S, A, D, GAMMA = 5, 2, 5, 0.6
ACTION_VALUE = 0.9  # discrete action a in {0, 1} is the continuous action +-0.9


class TabularB(nn.Module):
    def __init__(self, gen: torch.Generator) -> None:
        super().__init__()
        self.table = nn.Parameter(torch.eye(S, D) + 0.1 * torch.randn(S, D, generator=gen))

    def forward(self, obs: torch.Tensor) -> torch.Tensor:
        return obs @ self.table


class TabularF(nn.Module):
    """Two heads F^k[s, a], equal at initialisation."""

    def __init__(self, gen: torch.Generator) -> None:
        super().__init__()
        init = 0.1 * torch.randn(1, S * A, D, generator=gen)
        self.table = nn.Parameter(init.repeat(2, 1, 1))

    def forward(self, obs: torch.Tensor, z: torch.Tensor, action: torch.Tensor) -> torch.Tensor:
        row = obs.argmax(-1) * A + (action[:, 0] > 0).long()
        # + 0 * action: the actor's loss keeps a graph (its one parameter gets a zero grad).
        return self.table[:, row] + 0 * action[:, :1]  # (2, n, d)


class FixedActor(nn.Module):
    """mu(s, z) = +-0.9 by a fixed table; the smoothing noise (clipped to 0.3) never flips
    the sign, so pi(s) is deterministic."""

    def __init__(self, choice: torch.Tensor) -> None:
        super().__init__()
        self.values: torch.Tensor
        self.register_buffer("values", (2 * choice.float() - 1) * ACTION_VALUE)
        self.unused = nn.Parameter(torch.zeros(()))

    def forward(self, obs: torch.Tensor, z: torch.Tensor) -> torch.Tensor:
        return (obs @ self.values)[:, None] + 0 * self.unused


def finite_mdp() -> tuple[np.ndarray, np.ndarray]:
    """P (S, A, S) and the policy pi (S,) of the test."""
    rng = np.random.default_rng(0)
    p = rng.random((S, A, S)) ** 5  # peaked: the two actions lead to different places
    return p / p.sum(-1, keepdims=True), rng.integers(0, A, S)


def random_walk_dataset(p: np.ndarray, episodes: int = 100, length: int = 60) -> Dataset:
    rng = np.random.default_rng(1)
    obs, act = [], []
    for _ in range(episodes):
        s = int(rng.integers(S))
        states, actions = [s], [0]
        for _ in range(length):
            a = int(rng.integers(A))
            s = int(rng.choice(S, p=p[s, a]))
            states.append(s)
            actions.append(a)
        obs.append(np.eye(S, dtype=np.float32)[states])
        act.append(((2 * np.array(actions, np.float32) - 1) * ACTION_VALUE)[:, None])
    observation, action = np.concatenate(obs), np.concatenate(act)
    starts = np.arange(episodes) * (length + 1)
    discount = np.ones(len(observation), np.float32)
    return Dataset(Path("tabular"), "tabular", [], observation, action, discount, starts)


def fixed_point(trainer: FBTrainer, pi: np.ndarray, nstep: int) -> torch.Tensor:
    """m = (I - gamma^n C Pi)^-1 A from the windows the trainer samples, (S A, S)."""
    states = trainer.obs.argmax(-1)
    acts = (trainer.action[:, 0] > 0).long()
    nxt = trainer.next_index
    rows = torch.arange(len(nxt)) if nstep == 1 else trainer.nstep_rows
    j = nxt[rows]
    sa = states[j - 1] * A + acts[j]
    eye = torch.eye(S, dtype=torch.float64)
    a_sum = torch.stack([GAMMA**k * eye[states[nxt[rows + k]]] for k in range(nstep)]).sum(0)
    c_sum = eye[states[nxt[rows + nstep - 1]]]
    count = torch.bincount(sa, minlength=S * A).double()
    a_mat = torch.zeros(S * A, S, dtype=torch.float64).index_add_(0, sa, a_sum) / count[:, None]
    c_mat = torch.zeros(S * A, S, dtype=torch.float64).index_add_(0, sa, c_sum) / count[:, None]
    select = torch.zeros(S, S * A, dtype=torch.float64)
    select[torch.arange(S), torch.arange(S) * A + torch.as_tensor(pi)] = 1.0
    lhs = torch.eye(S * A, dtype=torch.float64) - GAMMA**nstep * c_mat @ select
    return torch.linalg.solve(lhs, a_mat)


def train_tabular(nstep: int, updates: int) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """(learned m, its n-step fixed point, the one-step fixed point M^pi), (S A, S) each,
    after `updates` updates of the trainer, all from the trainer's own data."""
    p, pi = finite_mdp()
    mcfg = FBModelConfig(S, 1, z_dim=D, b_hidden=4, b_norm="none", f_hidden=4, f_embed=4)
    tcfg = FBTrainConfig(  # steps: the run is short, so the trainer runs eagerly
        batch_size=256, gamma=GAMMA, tau=0.05, nstep=nstep, precision="fp32", steps=updates
    )
    trainer = FBTrainer(mcfg, tcfg, random_walk_dataset(p))
    gen = torch.Generator().manual_seed(0)
    b_net, f_net, actor = TabularB(gen), TabularF(gen), FixedActor(torch.as_tensor(pi))
    model = trainer.model
    model.backward_net = b_net  # type: ignore[assignment]
    model.forward_net = f_net  # type: ignore[assignment]
    model.actor = actor  # type: ignore[assignment]
    trainer.b_target = copy.deepcopy(b_net).requires_grad_(False)  # type: ignore[assignment]
    trainer.f_target = copy.deepcopy(f_net).requires_grad_(False)  # type: ignore[assignment]
    trainer.opt_fb = torch.optim.Adam([*f_net.parameters(), *b_net.parameters()])
    trainer.opt_actor = torch.optim.Adam(actor.parameters(), lr=0.0)
    for i in range(updates):
        for group in trainer.opt_fb.param_groups:  # 0.02 down to 0.001: a small noise floor
            group["lr"] = 0.02 * 0.05 ** (i / updates)
        trainer.update()
    with torch.no_grad():
        states = trainer.obs.argmax(-1)
        rows = torch.arange(len(trainer.next_index)) if nstep == 1 else trainer.nstep_rows
        rho = torch.bincount(states[trainer.next_index[rows]], minlength=S).double()
        rho /= rho.sum()
        f = f_net.table.double().mean(0)  # (S A, d), mean of the two heads
        learned = f @ b_net.table.double().T * rho
    return learned, fixed_point(trainer, pi, nstep), fixed_point(trainer, pi, 1)


def relative_error(a: torch.Tensor, b: torch.Tensor) -> float:
    return float((a - b).abs().max() / b.abs().max())


@pytest.mark.parametrize("nstep", [1, 2])
def test_fb_training_converges_to_the_successor_measure(nstep: int) -> None:
    """1000 updates bring F^T B rho within 4 % (max error over max entry) of the loss's
    fixed point: M^pi for the one-step loss; for 2-step targets the "beta, then pi" measure,
    which here lies over 20 % away from M^pi (measured: ~1 % and ~2 % from the fixed
    points, 28 % between them)."""
    learned, target, one_step = train_tabular(nstep, updates=1000)
    assert relative_error(learned, target) < 0.04
    if nstep > 1:
        assert relative_error(target, one_step) > 0.2
        assert relative_error(learned, one_step) > 0.2
