"""FB-IL against closed-form successor measures (paper Theorems 2-5, formulas (8), (9)).

In a finite MDP with an exact FB model, every loss of fbil is compared with the
successor-measure distance it is derived from, the reward-based z with FB's reward
formula z_r = E_rho[r(s) B(s)], and the expert's own z must minimise each loss. Every test
runs on both tabular representations: B(s) = e_s (diagonal: every matrix commutes) and
B(s) = Q e_s (dense: order, transpose and elementwise-for-matrix bugs show)."""

import math

import numpy as np
import pytest
import torch

from fbil.imitation import from_arrays, imitate
from fbil.imitation.core import DemoBatch, prepare
from fbil.imitation.methods import bc, bellman, matching
from fbil.imitation.methods.reward import erfb, rerfb
from tests.imitation.tabular import TabularFB

pytestmark = pytest.mark.usefixtures("float64")


def expert_batch(fb: TabularFB, z_expert: torch.Tensor) -> tuple[DemoBatch, torch.Tensor]:
    """Every (s, a, s') with weight rho_e(s) pi_e(a|s) P(s'|s,a): the exact expectations a
    demonstration estimates. G(s) is the expert's successor features int B dM^e(s)."""
    s_, a_ = fb.S, fb.A
    pi_e = fb.policy(z_expert)
    m_e = fb.successor(pi_e)
    rho_e = torch.linspace(1.0, 2.0, s_) / torch.linspace(1.0, 2.0, s_).sum()
    eye_s, eye_a = torch.eye(s_), torch.eye(a_)
    rows = [(s, a, t) for s in range(s_) for a in range(a_) for t in range(s_)]
    w = torch.tensor([float(rho_e[s] * pi_e[s, a] * fb.P[s, a, t]) for s, a, t in rows])
    batch = DemoBatch(
        obs=eye_s[[r[0] for r in rows]],
        next_obs=eye_s[[r[2] for r in rows]],
        action=eye_a[[r[1] for r in rows]],
        weight=w / w.sum(),
        b_next=fb.B[[r[2] for r in rows]],
        g=fb.features(m_e)[[r[0] for r in rows]],
        traj=torch.zeros(len(rows), dtype=torch.long),
        step=torch.arange(len(rows)),
        gamma=fb.gamma,
    )
    return batch, rho_e


def random_zs(fb: TabularFB, n: int = 4) -> list[torch.Tensor]:
    g = torch.Generator().manual_seed(1)
    return [fb.project_z(torch.randn(fb.z_dim, generator=g)) for _ in range(n)]


# -- (a) reward-based and goal-based z follow their formulas -----------------------------------
def test_erfb_and_rerfb_are_fb_reward_inference_of_their_rewards(fb: TabularFB) -> None:
    states = [0, 2, 2, 5, 2, 0, 3]  # one demonstration s_0 .. s_6
    obs = np.eye(fb.S)[states]
    batch = prepare(fb, from_arrays([obs]), fb.gamma)
    p_e = torch.bincount(torch.tensor(states[1:]), minlength=fb.S).double() / 6  # rho_e
    # z_r = E_rho[r(s) B(s)] = sum_s rho_s r(s) B(s).
    z_er, _ = erfb(fb, batch)  # r = rho_e / rho
    torch.testing.assert_close(z_er, fb.project_z((fb.rho * (p_e / fb.rho)) @ fb.B))
    z_rer, _ = rerfb(fb, batch)  # r = rho_e / (rho + rho_e)
    torch.testing.assert_close(z_rer, fb.project_z((fb.rho * p_e / (fb.rho + p_e)) @ fb.B))


def test_goalfb_targets_the_state_k_steps_ahead(fb: TabularFB) -> None:
    states = [0, 1, 2, 3, 4, 5, 4, 3]
    policy = imitate(fb, from_arrays([np.eye(fb.S)[states]]), "goalfb", lookahead=3)
    assert policy.z.shape == (len(states), fb.S)
    for t in range(len(states)):
        goal = states[min(t + 3, len(states) - 1)]
        torch.testing.assert_close(policy.z_at(t), fb.project_z(fb.B[goal]))


def test_discounted_features_are_the_truncated_discounted_sums(fb: TabularFB) -> None:
    states = [1, 3, 0, 4, 4]
    batch = prepare(fb, from_arrays([np.eye(fb.S)[states]]), 0.5)
    for t in range(4):
        expected = sum(0.5**k * fb.B[states[t + k + 1]] for k in range(4 - t))
        torch.testing.assert_close(batch.g[t], expected)


# -- (b) each loss is the distance it is derived from -----------------------------------------
def l2_rho_sq(fb: TabularFB, m: torch.Tensor) -> torch.Tensor:
    """|m|^2 in the dual of L2(rho), per row: sum_s' (m(s')/rho(s'))^2 rho(s')."""
    return ((m / fb.rho) ** 2 * fb.rho).sum(-1)


def test_fmfb_loss_is_the_b_feature_distance_of_successor_measures(fb: TabularFB) -> None:
    z_e = random_zs(fb)[0]
    batch, rho_e = expert_batch(fb, z_e)
    m_e = fb.successor(fb.policy(z_e))
    for z in random_zs(fb)[1:]:
        m_z = fb.successor(fb.policy(z))
        # (13): |int B dM^z(s) - int B dM^e(s)|^2 (with B(s) = e_s: |M^z(s) - M^e(s)|^2).
        expected = (rho_e * (fb.features(m_z - m_e) ** 2).sum(-1)).sum()
        torch.testing.assert_close(matching.fm_loss(fb, batch, z), expected)


def test_dmfb_loss_is_the_l2_distance_up_to_a_constant(fb: TabularFB) -> None:
    z_e = random_zs(fb)[0]
    batch, rho_e = expert_batch(fb, z_e)
    m_e = fb.successor(fb.policy(z_e))
    gaps = []
    for z in random_zs(fb)[1:]:
        m_z = fb.successor(fb.policy(z))
        distance = (rho_e * l2_rho_sq(fb, m_z - m_e)).sum()
        gaps.append(matching.dm_loss(fb, batch, z) - distance)
    # The z-independent constant is -E_{rho_e} |M^e(s)|^2.
    for gap in gaps:
        torch.testing.assert_close(gap, -(rho_e * l2_rho_sq(fb, m_e)).sum())


@pytest.mark.parametrize("norm", ["B*", "L2"])
def test_bellman_losses_have_the_gradient_of_the_bellman_gap(fb: TabularFB, norm: str) -> None:
    z_e = random_zs(fb)[0]
    batch, rho_e = expert_batch(fb, z_e)
    p_e = fb.p_pi(fb.policy(z_e))
    code = bellman.bbell_loss if norm == "B*" else bellman.fbloss_loss
    for z0 in random_zs(fb)[1:]:
        z = z0.clone().requires_grad_(True)
        m_z = fb.successor(fb.policy(z))
        gap = m_z - p_e - fb.gamma * p_e @ m_z.detach()  # (15), stop-gradient on the right
        per_state = (fb.features(gap) ** 2).sum(-1) if norm == "B*" else l2_rho_sq(fb, gap)
        (g_theory,) = torch.autograd.grad((rho_e * per_state).sum(), z)
        (g_code,) = torch.autograd.grad(code(fb, batch, fb.project_z(z)), z)
        torch.testing.assert_close(g_code, g_theory)


def test_bc_loss_is_the_kl_to_the_expert_policy_up_to_a_constant(fb: TabularFB) -> None:
    z_e = random_zs(fb)[0]
    batch, rho_e = expert_batch(fb, z_e)
    pi_e = fb.policy(z_e)
    entropy = -(rho_e * (pi_e * pi_e.log()).sum(-1)).sum()
    for z in random_zs(fb)[1:]:
        pi_z = fb.policy(z)
        kl = (rho_e * (pi_e * (pi_e.log() - pi_z.log())).sum(-1)).sum()
        torch.testing.assert_close(bc.bc_loss(fb, batch, z), entropy + kl)


# -- (c) the expert's own z minimises every loss ---------------------------------------------
def test_the_experts_z_minimises_each_loss(fb: TabularFB) -> None:
    zs = random_zs(fb, 6)
    z_e = zs[0]
    batch, _ = expert_batch(fb, z_e)
    for loss in (bc.bc_loss, matching.fm_loss, matching.dm_loss):
        assert all(loss(fb, batch, z_e) < loss(fb, batch, z) for z in zs[1:])
    assert float(matching.fm_loss(fb, batch, z_e)) == pytest.approx(0.0, abs=1e-12)
    # Bellman losses (stop-gradient): the expert's z is a stationary point.
    for code in (bellman.bbell_loss, bellman.fbloss_loss):
        z = z_e.clone().requires_grad_(True)
        (grad,) = torch.autograd.grad(code(fb, batch, fb.project_z(z)), z)
        assert float(grad.norm()) < 1e-10


def test_gradient_methods_recover_the_experts_behaviour(fb: TabularFB) -> None:
    """From demonstrations sampled from the expert, FMFB and BCFB find a z whose policy is
    closer to the expert's than the ERFB warm start's is."""
    z_e = random_zs(fb)[0]
    pi_e = fb.policy(z_e)
    states, actions = fb.rollout(z_e, 3000)
    demos = from_arrays([np.eye(fb.S)[states]], [np.eye(fb.A)[actions]])

    def tv(z: torch.Tensor) -> float:
        return float((fb.policy(z) - pi_e).abs().sum(-1).mean())

    start = tv(imitate(fb, demos, "erfb").z)
    for method in ("bcfb", "fmfb"):
        assert tv(imitate(fb, demos, method).z) < start
    assert math.isfinite(start)
