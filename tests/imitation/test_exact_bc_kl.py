"""The library's own BC and KL losses against closed forms on the finite MDP.

BC (7): -E_{rho_e} ln pi_z(a_t | s_t); KL (57): -E_{rho_e} sum_k gamma^k
ln F(s_t, z)^T B(s_{t+k+1}), whose expectation is E_{rho_e} KL(M^e(s) || M^z(s)) up to a
z-independent constant (Theorem 6), with F^T B = M / rho from the closed-form M."""

from typing import Any

import numpy as np
import pytest
import torch

from fbil.errors import FbilError
from fbil.imitation import OptimiserConfig, from_arrays
from fbil.imitation.core import DemoBatch, FBLike, prepare
from fbil.imitation.methods import bc, kl
from tests.imitation.tabular import TabularFB

pytestmark = pytest.mark.usefixtures("float64")


def random_zs(fb: TabularFB, n: int = 4) -> list[torch.Tensor]:
    g = torch.Generator().manual_seed(1)
    return [fb.project_z(torch.randn(fb.z_dim, generator=g)) for _ in range(n)]


def two_demos(fb: TabularFB, z: torch.Tensor) -> tuple[list[list[int]], list[list[int]]]:
    """Two demonstrations of pi_z of different lengths (4 and 11 transitions)."""
    s1, a1 = fb.rollout(z, 4, start=0, seed=5)
    s2, a2 = fb.rollout(z, 11, start=3, seed=6)
    return [s1, s2], [a1, a2]


def kl_loss(model: FBLike, batch: DemoBatch, z: torch.Tensor) -> float:
    """The KLFB loss at z, read from the library's optimiser (one full-batch step, lr 0)."""
    cfg = OptimiserConfig(lr=0.0, steps=1, batch_size=None, precision="fp32")
    _, info = kl.klfb(model, batch, z, cfg)
    return float(info["loss_first"])


# -- BC ---------------------------------------------------------------------------------------
def test_bc_loss_pairs_each_action_with_its_own_state(fb: TabularFB) -> None:
    """On real demonstrations (through prepare), -sum_t ln pi_z(a_t | s_t) per demo, each
    demo weighted equally."""
    z_e, *others = random_zs(fb)
    states, actions = two_demos(fb, z_e)
    demos = from_arrays([np.eye(fb.S)[s] for s in states], [np.eye(fb.A)[a] for a in actions])
    batch = prepare(fb, demos, fb.gamma)
    for z in [z_e, *others]:
        logp = fb.policy(z).log()
        expected = -sum(
            0.5 * np.mean([float(logp[s[t], a[t]]) for t in range(len(a))])
            for s, a in zip(states, actions, strict=True)
        )
        assert float(bc.bc_loss(fb, batch, z)) == pytest.approx(expected, rel=1e-10)


def test_bc_likelihood_is_maximal_at_the_experts_z(fb: TabularFB) -> None:
    """The expected BC loss (every (s, a) weighted by rho_e(s) pi_e(a|s)) is stationary at
    z_e and larger anywhere else; on one long sampled demo z_e also beats other z."""
    zs = random_zs(fb, 6)
    z_e = zs[0]
    pi_e = fb.policy(z_e)
    rho_e = torch.linspace(1.0, 2.0, fb.S) / torch.linspace(1.0, 2.0, fb.S).sum()
    rows = [(s, a) for s in range(fb.S) for a in range(fb.A)]
    w = torch.tensor([float(rho_e[s] * pi_e[s, a]) for s, a in rows])
    obs = torch.eye(fb.S)[[s for s, _ in rows]]
    batch = DemoBatch(
        obs=obs,
        next_obs=obs,
        action=torch.eye(fb.A)[[a for _, a in rows]],
        weight=w,
        b_next=fb.backward(obs),
        g=fb.backward(obs),
        traj=torch.zeros(len(rows), dtype=torch.long),
        step=torch.arange(len(rows)),
        gamma=fb.gamma,
    )
    z = z_e.clone().requires_grad_(True)
    (grad,) = torch.autograd.grad(bc.bc_loss(fb, batch, fb.project_z(z)), z)
    assert float(grad.norm()) < 1e-10
    assert all(bc.bc_loss(fb, batch, z_e) < bc.bc_loss(fb, batch, z) for z in zs[1:])

    states, actions = fb.rollout(z_e, 2000)
    demo = prepare(fb, from_arrays([np.eye(fb.S)[states]], [np.eye(fb.A)[actions]]), fb.gamma)
    assert all(bc.bc_loss(fb, demo, z_e) < bc.bc_loss(fb, demo, z) for z in zs[1:])


# -- KL ---------------------------------------------------------------------------------------
def test_kl_loss_on_demonstrations_is_the_discounted_log_density_sum(fb: TabularFB) -> None:
    """(57) on two demos of different lengths: -sum_t w_t sum_k gamma^k ln(M^z(s_t,
    s_{t+k+1}) / rho(s_{t+k+1})), truncated at each demo's end, w_t = 1 / (2 len)."""
    z_e, *others = random_zs(fb)
    states, _ = two_demos(fb, z_e)
    batch = prepare(fb, from_arrays([np.eye(fb.S)[s] for s in states]), fb.gamma)
    for z in [z_e, *others]:
        density = (fb.successor(fb.policy(z)) / fb.rho).log()
        expected = 0.0
        for s in states:
            n = len(s) - 1
            for t in range(n):
                for k in range(n - t):
                    expected -= fb.gamma**k * float(density[s[t], s[t + k + 1]]) / (2 * n)
        assert kl_loss(fb, batch, z) == pytest.approx(expected, rel=1e-6)


def test_kl_loss_is_the_kl_of_successor_measures_up_to_a_constant(fb: TabularFB) -> None:
    """Theorem 6: with every (s, s') weighted by rho_e(s) M^e(s, s') (1 - gamma), the loss
    divided by (1 - gamma) is E_{rho_e} KL(M^e(s) || M^z(s)) - E_{rho_e} int ln(dM^e/drho)
    dM^e(s): the generalised KL, whose mass terms cancel (every M(s) has mass
    1 / (1 - gamma))."""
    zs = random_zs(fb, 5)
    z_e = zs[0]
    m_e = fb.successor(fb.policy(z_e))
    rho_e = torch.linspace(1.0, 2.0, fb.S) / torch.linspace(1.0, 2.0, fb.S).sum()
    rows = [(s, t) for s in range(fb.S) for t in range(fb.S)]
    w = torch.tensor([float(rho_e[s] * m_e[s, t]) for s, t in rows]) * (1 - fb.gamma)
    obs = torch.eye(fb.S)[[s for s, _ in rows]]
    nxt = torch.eye(fb.S)[[t for _, t in rows]]
    batch = DemoBatch(  # one single-transition "trajectory" per (s, s'): k = 0 only
        obs=obs,
        next_obs=nxt,
        action=None,
        weight=w,
        b_next=fb.backward(nxt),
        g=fb.backward(nxt),
        traj=torch.arange(len(rows)),
        step=torch.zeros(len(rows), dtype=torch.long),
        gamma=fb.gamma,
    )
    constant = -float((rho_e[:, None] * m_e * (m_e / fb.rho).log()).sum())
    losses = []
    for z in zs:
        m_z = fb.successor(fb.policy(z))
        gen_kl = m_e * (m_e / m_z).log() - m_e + m_z
        divergence = float((rho_e[:, None] * gen_kl).sum())
        losses.append(kl_loss(fb, batch, z) / (1 - fb.gamma))
        assert losses[-1] == pytest.approx(divergence + constant, rel=1e-6, abs=1e-6)
    assert all(losses[0] < other for other in losses[1:])


class _SignFlip:
    """The tabular FB with F negated on the states in `flipped` (its density F^T B < 0 on
    every pair that starts there)."""

    def __init__(self, fb: TabularFB, flipped: list[int]) -> None:
        self.fb, self.flipped = fb, torch.tensor(flipped)

    def __getattr__(self, name: str) -> Any:
        return getattr(self.fb, name)

    def forward(self, obs: torch.Tensor, z: torch.Tensor) -> torch.Tensor:
        sign = 1.0 - 2.0 * obs[:, self.flipped].sum(-1, keepdim=True).clamp(max=1.0)
        return self.fb.forward(obs, z) * sign


def test_klfb_tolerates_a_few_nonpositive_pairs_and_refuses_a_majority(fb: TabularFB) -> None:
    """Pairs with F^T B <= 0 are constant in the loss: a model where they are rare still
    gives a finite z, and one where they carry most of the weight is refused in one line."""
    z_e, *_ = random_zs(fb)
    states, _ = two_demos(fb, z_e)
    batch = prepare(fb, from_arrays([np.eye(fb.S)[s] for s in states]), fb.gamma)
    cfg = OptimiserConfig(lr=0.01, steps=5, batch_size=None, precision="fp32")
    rare = _SignFlip(fb, [int(states[1][0])])  # one start state of the 11-step demo
    z, _ = kl.klfb(rare, batch, z_e, cfg)  # type: ignore[arg-type]
    assert torch.isfinite(z).all()
    everywhere = _SignFlip(fb, list(range(fb.S)))
    with pytest.raises(FbilError, match=r"klfb needs .* non-positive values on 100\.0%"):
        kl.klfb(everywhere, batch, z_e, cfg)  # type: ignore[arg-type]
