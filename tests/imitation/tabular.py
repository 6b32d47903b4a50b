"""An exact FB model of a small finite MDP, for tests where theory gives exact answers.

States are one-hot observations; B(s) = e_s (d = number of states), so Cov B = diag(rho);
the policy family is pi_z(a|s) = softmax_a(W[s, a] . z) for a fixed random W; and
F(s, a, z) = M^{pi_z}(s, a, .) / rho with M^pi(s, a, .) = P(s, a, .) (I - gamma P_pi)^-1,
so that M^{pi_z} = F B^T rho holds exactly.
"""

from __future__ import annotations

import math

import torch


class TabularFB:
    def __init__(
        self, n_states: int = 6, n_actions: int = 3, gamma: float = 0.8, seed: int = 0
    ) -> None:
        g = torch.Generator().manual_seed(seed)
        self.S, self.A, self.gamma = n_states, n_actions, gamma
        self.z_dim = n_states
        self.P = torch.rand(n_states, n_actions, n_states, generator=g, dtype=torch.float64) ** 3
        self.P /= self.P.sum(-1, keepdim=True)
        self.rho = torch.rand(n_states, generator=g, dtype=torch.float64) + 0.5
        self.rho /= self.rho.sum()
        self.cov_b = torch.diag(self.rho)
        self.W = torch.randn(n_states, n_actions, n_states, generator=g, dtype=torch.float64)
        self.metadata = {"train_config": {"gamma": gamma}}

    # -- the exact quantities --------------------------------------------------------------
    def project_z(self, z: torch.Tensor) -> torch.Tensor:
        z = torch.as_tensor(z, dtype=torch.float64)
        return math.sqrt(self.z_dim) * torch.nn.functional.normalize(z, dim=-1)

    def policy(self, z: torch.Tensor) -> torch.Tensor:
        """(S, A) action probabilities of pi_z."""
        return torch.softmax(self.W @ self.project_z(z), dim=-1)

    def p_pi(self, pi: torch.Tensor) -> torch.Tensor:
        return torch.einsum("sa,sat->st", pi, self.P)

    def successor(self, pi: torch.Tensor) -> torch.Tensor:
        """State successor measure M^pi(s, .) = P_pi (I - gamma P_pi)^-1, (S, S)."""
        p = self.p_pi(pi)
        return p @ torch.linalg.inv(torch.eye(self.S, dtype=p.dtype) - self.gamma * p)

    # -- the FBLike interface (observations are one-hot rows) -------------------------------
    def backward(self, obs: torch.Tensor) -> torch.Tensor:
        return torch.as_tensor(obs, dtype=torch.float64)

    def forward(self, obs: torch.Tensor, z: torch.Tensor) -> torch.Tensor:
        z0 = z.reshape(-1, self.z_dim)[0]  # one z for the whole batch in these tests
        f = self.successor(self.policy(z0)) / self.rho  # F(s, z) for every s, (S, d)
        return torch.as_tensor(obs, dtype=torch.float64) @ f

    def log_prob(self, obs: torch.Tensor, z: torch.Tensor, action: torch.Tensor) -> torch.Tensor:
        """action: one-hot rows."""
        z0 = z.reshape(-1, self.z_dim)[0]
        logp = torch.log(self.policy(z0))  # (S, A)
        obs = torch.as_tensor(obs, dtype=torch.float64)
        return ((obs @ logp) * torch.as_tensor(action, dtype=torch.float64)).sum(-1)

    def act(self, obs: torch.Tensor, z: torch.Tensor) -> torch.Tensor:
        z0 = z.reshape(-1, self.z_dim)[0]
        return torch.nn.functional.one_hot(
            (torch.as_tensor(obs, dtype=torch.float64) @ self.policy(z0)).argmax(-1), self.A
        ).double()
