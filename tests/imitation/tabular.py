"""An exact FB model of a small finite MDP, for tests where theory gives exact answers.

States are one-hot observations; the policy family is pi_z(a|s) = softmax_a(W[s, a] . z)
for a fixed random W. Two representations:

- diagonal (`dense=False`): B(s) = e_s (d = number of states), so Cov B = diag(rho) and
  every matrix of FB-IL is diagonal: symmetric and commuting;
- dense (`dense=True`): B(s) = Q e_s for a random, invertible, non-orthogonal Q, so that
  Cov B = Q diag(rho) Q^T and E_{rho_e}[B B^T] = Q diag(rho_e) Q^T do not commute and a
  product written in the wrong order, or an elementwise product for a matrix one, changes
  the result.

In both, F(s, z) is chosen so that F(s, z)^T B(s') = M^{pi_z}(s, s') / rho(s'), with
M^pi(s, .) = P_pi(s, .) (I - gamma P_pi)^-1: the FB model (2) holds exactly.
"""

from __future__ import annotations

import math

import torch


class TabularFB:
    def __init__(
        self,
        n_states: int = 6,
        n_actions: int = 3,
        gamma: float = 0.8,
        seed: int = 0,
        dense: bool = False,
    ) -> None:
        g = torch.Generator().manual_seed(seed)
        self.S, self.A, self.gamma = n_states, n_actions, gamma
        self.z_dim = n_states
        self.P = torch.rand(n_states, n_actions, n_states, generator=g, dtype=torch.float64) ** 3
        self.P /= self.P.sum(-1, keepdim=True)
        self.rho = torch.rand(n_states, generator=g, dtype=torch.float64) + 0.5
        self.rho /= self.rho.sum()
        self.W = torch.randn(n_states, n_actions, n_states, generator=g, dtype=torch.float64)
        eye = torch.eye(n_states, dtype=torch.float64)
        if dense:
            # Rows are B(s): a random matrix far from orthogonal and well conditioned.
            noise = torch.randn(n_states, n_states, generator=g, dtype=torch.float64)
            scale = torch.linspace(0.5, 2.0, n_states, dtype=torch.float64)
            self.B = (eye + 0.6 * noise / math.sqrt(n_states)) * scale
        else:
            self.B = eye
        self.B_inv = torch.linalg.inv(self.B)
        self.dense = dense
        self.cov_b = self.B.T @ torch.diag(self.rho) @ self.B  # E_rho[B B^T]
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

    def features(self, m: torch.Tensor) -> torch.Tensor:
        """int B dm for measures m given as rows over states: (..., S) -> (..., d)."""
        return m @ self.B

    # -- the FBLike interface (observations are one-hot rows) -------------------------------
    def backward(self, obs: torch.Tensor) -> torch.Tensor:
        return torch.as_tensor(obs, dtype=torch.float64) @ self.B

    def forward(self, obs: torch.Tensor, z: torch.Tensor) -> torch.Tensor:
        z0 = z.reshape(-1, self.z_dim)[0]  # one z for the whole batch in these tests
        # F(s, z)^T B(s') = M(s, s') / rho(s') for all s': F = (M / rho) B^-T, rows F(s, z).
        f = (self.successor(self.policy(z0)) / self.rho) @ self.B_inv.T
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

    # -- sampling ------------------------------------------------------------------------
    def rollout(
        self, z: torch.Tensor, steps: int, start: int = 0, seed: int = 3
    ) -> tuple[list[int], list[int]]:
        """States s_0..s_T and actions a_0..a_{T-1} of pi_z."""
        g = torch.Generator().manual_seed(seed)
        pi = self.policy(z)
        states, actions = [start], []
        for _ in range(steps):
            a = int(torch.multinomial(pi[states[-1]], 1, generator=g))
            actions.append(a)
            states.append(int(torch.multinomial(self.P[states[-1], a], 1, generator=g)))
        return states, actions
