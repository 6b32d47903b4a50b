"""The paper's conditioned networks (App. D.3, DIAYN's and GOAL-TD3's) for a TD3 whose
input is a state s followed by a conditioning vector c (a goal state, a skill):

  actor   pi(s, c)    = tanh(head([enc_s(s), enc_sc(s, c)]))
  critic  Q(s, a, c)  = head([enc_sa(s, a), enc_sc(s, c)])

Each encoder is one hidden layer (layer norm + tanh, as every first layer here) to an
embedding of half the width, then ReLU (`fbil.fb.model.embedding`, F's and the FB
actor's); each head is two ReLU layers of the full width and a linear output. At the
paper's width 1024 the embeddings are 512. One difference, recorded: the paper's twin
critics share their two encoders; here each critic has its own, as TD3's two critics are
separate networks (`TD3.critics`).

Each network takes the same flat input as `fbil.agents.td3`'s MLP ([s, c] for the actor,
[s, c, a] for a critic) and splits it itself, so TD3 uses either kind unchanged.
"""

from __future__ import annotations

import torch
from torch import nn

from fbil.fb.model import embedding


def _head(inp: int, hidden: int) -> nn.Sequential:
    return nn.Sequential(nn.Linear(inp, hidden), nn.ReLU(), nn.Linear(hidden, hidden), nn.ReLU())


class TwoStreamActor(nn.Module):
    """pi's pre-tanh output from x = [s, c]."""

    def __init__(self, state_dim: int, cond_dim: int, act_dim: int, hidden: int) -> None:
        super().__init__()
        self.state_dim, embed = state_dim, hidden // 2
        self.s = embedding(state_dim, hidden, embed)
        self.sc = embedding(state_dim + cond_dim, hidden, embed)
        self.body = _head(2 * embed, hidden)
        self.out = nn.Linear(hidden, act_dim)

    def features(self, x: torch.Tensor) -> torch.Tensor:
        return self.body(torch.cat([self.s(x[..., : self.state_dim]), self.sc(x)], -1))

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.out(self.features(x))


class TwoStreamCritic(nn.Module):
    """Q from x = [s, c, a]."""

    def __init__(self, state_dim: int, cond_dim: int, act_dim: int, hidden: int) -> None:
        super().__init__()
        self.state_dim, self.cond_dim, embed = state_dim, cond_dim, hidden // 2
        self.sa = embedding(state_dim + act_dim, hidden, embed)
        self.sc = embedding(state_dim + cond_dim, hidden, embed)
        self.body = _head(2 * embed, hidden)
        self.out = nn.Linear(hidden, 1)

    def features(self, x: torch.Tensor) -> torch.Tensor:
        split = self.state_dim + self.cond_dim
        sa = torch.cat([x[..., : self.state_dim], x[..., split:]], -1)
        return self.body(torch.cat([self.sa(sa), self.sc(x[..., :split])], -1))

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.out(self.features(x))
