"""The objectives of SQIL, DWBC, the DICE family and IQ-Learn, each against what it should
recover: SQIL's labels and balanced minibatches, SAC's tanh-Gaussian log-likelihood, DWBC's
discriminator and weights on a toy batch, the DICE duals on a finite MDP with known
transitions (one-hot states, so the optimum is exact) and IQ-Learn's Q on a tabular chain."""

from pathlib import Path
from typing import Any

import pytest
import torch
from torch import distributions as D

from fbil.agents.td3 import run_mlp
from fbil.baselines import demodice, lobsdice, smodice, sqil
from fbil.baselines.common import Transitions
from fbil.baselines.dice import (
    DualConfig,
    advantage,
    chi2_conjugate,
    dice_weights,
    dual_loss,
    effective_share,
)
from fbil.baselines.dwbc import DWBC, DWBCConfig, discriminator_loss, policy_weights
from fbil.baselines.iqlearn import iq_loss
from fbil.baselines.offline_td3 import MixedSampler
from fbil.baselines.sac import SAC, SACConfig
from fbil.config import config_from_dict
from fbil.data import load_dataset
from fbil.errors import FbilError


def _rows(obs: torch.Tensor, action: torch.Tensor | None, next_obs: torch.Tensor) -> Transitions:
    n = len(obs)
    return Transitions(obs, action, next_obs, torch.ones(n, dtype=obs.dtype), torch.zeros(n) > 0)


class _Recorder:
    """Stands in for the SAC agent: keeps the rewards it is given."""

    def update(self, batch: Transitions, reward: torch.Tensor) -> dict[str, float]:
        self.batch, self.reward = batch, reward
        return {}


@pytest.mark.parametrize("budget", ["cpu", "smoke"])
def test_sqil_balances_minibatches_and_labels_expert_rows_1(
    budget: str, fixture_data: Path
) -> None:
    cfg = sqil.BUDGETS[budget]
    dataset = load_dataset(fixture_data)
    gen = torch.Generator().manual_seed(0)
    expert = _rows(torch.randn(7, 4, generator=gen), torch.zeros(7, 2), torch.randn(7, 4))
    expert.expert[:] = True
    size = cfg.sac.batch_size
    batch = MixedSampler(dataset, expert, size, cfg.expert_ratio, gen)()
    assert len(batch) == size and int(batch.expert.sum()) == size // 2
    agent = _Recorder()
    info = sqil.sqil_update(agent, batch)  # type: ignore[arg-type]
    assert torch.equal(agent.reward, batch.expert.float()) and info["reward_mean"] == 0.5
    from_demos = (batch.obs[batch.expert, None] == expert.obs[None]).all(-1).any(-1)
    assert bool(from_demos.all())


@pytest.mark.parametrize("precision", ["fp32", "bf16"])
def test_sac_log_likelihood_is_the_tanh_gaussians(fixture_data: Path, precision: str) -> None:
    cfg = SACConfig(hidden=16, precision=precision)  # type: ignore[arg-type]
    agent = SAC(load_dataset(fixture_data), cfg, seed=0)
    obs = torch.randn(64, 4)
    gen_state = agent.gen.get_state()
    action, log_pi = agent.sample(obs)
    agent.gen.set_state(gen_state)
    out = run_mlp(agent.actor, agent.norm(obs), precision)
    mean, log_std = out[:, :2], out[:, 2:].clamp(-5, 2)
    eps = torch.randn(mean.shape, generator=agent.gen)
    u = mean + log_std.exp() * eps
    dist = D.TransformedDistribution(D.Normal(mean, log_std.exp()), [D.TanhTransform()])
    torch.testing.assert_close(action, torch.tanh(u))
    torch.testing.assert_close(log_pi, dist.log_prob(torch.tanh(u)).sum(-1), atol=2e-3, rtol=1e-4)


def _toy(n: int, expert_like: bool, gen: torch.Generator) -> Transitions:
    """States N(0, I); expert-like actions tanh(1.5 s[:2]), the others uniform."""
    s = torch.randn(n, 3, generator=gen)
    a = torch.tanh(1.5 * s[:, :2]) if expert_like else torch.rand(n, 2, generator=gen) * 2 - 1
    return _rows(s, a, s)


def test_dwbc_discriminator_separates_expert_pairs_and_weighs_them_up() -> None:
    # The loss and the weights in closed form.
    logit_e, logit_o = torch.tensor([0.3, 2.0]), torch.tensor([-1.0, 0.5])
    d_e, d_o = torch.sigmoid(logit_e), torch.sigmoid(logit_o)
    written = 0.5 * -torch.log(d_e).mean() - torch.log(1 - d_o).mean()
    written = written + 0.5 * torch.log(1 - d_e).mean()
    torch.testing.assert_close(discriminator_loss(logit_e, logit_o, 0.5), written)
    # d is clipped to [0.1, 0.9] as the authors' discriminator outputs it: rows past the
    # clip (an expert row at d = 0.95, a dataset row at d = 0.05) give no gradient.
    far = (
        torch.tensor([3.0, 0.3], requires_grad=True),
        torch.tensor([-3.0, 0.5], requires_grad=True),
    )
    discriminator_loss(*far, 0.5).backward()
    assert far[0].grad is not None and far[1].grad is not None
    assert float(far[0].grad[0]) == 0.0 and float(far[1].grad[0]) == 0.0
    assert float(far[0].grad[1]) < 0.0 < float(far[1].grad[1])
    w_e, w_o = policy_weights(
        torch.tensor([0.05, 0.5]), torch.tensor([0.2, 0.49, 0.6, 0.99]), 10.0, 0.5
    )
    torch.testing.assert_close(w_e, torch.tensor([9.0 - 0.5 / 0.09, 9.0 - 2.0]))
    # Dataset pairs the discriminator calls non-expert (d < 0.5) do not enter L_pi at all.
    torch.testing.assert_close(w_o, torch.tensor([0.0, 0.0, 0.6 / 0.4, 0.9 / 0.1]))
    # Trained on demos and an unlabeled set of 1 expert-like pair in 8.
    torch.manual_seed(0)
    gen = torch.Generator().manual_seed(0)
    expert = _toy(256, True, gen)
    mixed = [_toy(64, True, gen), _toy(448, False, gen)]
    data = _rows(
        *(torch.cat([getattr(m, k) for m in mixed]) for k in ("obs", "action", "next_obs"))
    )
    stats = torch.stack([torch.zeros(3), torch.ones(3)])
    model = DWBC(stats, 2, DWBCConfig(hidden=32, batch_size=128, lr=1e-3))
    for _ in range(300):
        pick = torch.randint(0, 256, (128,), generator=gen)
        rows = torch.randint(0, 512, (128,), generator=gen)
        model.update(expert.select(pick), data.select(rows))
    with torch.no_grad():
        good, bad = _toy(500, True, gen), _toy(500, False, gen)
        d_good = torch.sigmoid(model.logits(good, model.log_prob(good)))
        d_bad = torch.sigmoid(model.logits(bad, model.log_prob(bad)))
    auc = (d_good[:, None] > d_bad[None]).float().mean()
    assert auc > 0.85, auc
    _, w_good = policy_weights(d_good, d_good, 10.0, 0.5)
    _, w_bad = policy_weights(d_bad, d_bad, 10.0, 0.5)
    assert w_good.mean() > 2 * w_bad.mean(), (w_good.mean(), w_bad.mean())
    # The policy imitates the expert, not the unlabeled set's random actions: its mean
    # action is as close to tanh(1.5 s) as BC's on the demos alone would be (uniform
    # actions would sit ~0.6 away on average).
    with torch.no_grad():
        mean = torch.tanh(model.policy(good.obs)[:, :2])
    err = (mean - good.action).abs().mean()
    assert err < 0.15, err


class Chain:
    """5 states on a line, actions left / stay / right (deterministic, clamped at the
    ends), start at state 0, gamma 0.8; the expert goes right w.p. 0.7, stays w.p. 0.2.
    The dataset holds every (s, a) once (d_D uniform); states are one-hot."""

    S, A, gamma = 5, 3, 0.8

    def __init__(self) -> None:
        S, A = self.S, self.A
        f64 = torch.float64
        self.s = torch.arange(S).repeat_interleave(A)
        self.a = torch.arange(A).repeat(S)
        self.next = (self.s + self.a - 1).clamp(0, S - 1)
        pi = torch.tensor([0.1, 0.2, 0.7], dtype=f64)
        step = torch.zeros(S, S, dtype=f64).index_put_((self.s, self.next), pi.repeat(S), True)
        p0 = torch.zeros(S, dtype=f64)
        p0[0] = 1
        self.p0 = p0
        d_s = torch.linalg.solve(
            torch.eye(S, dtype=f64) - self.gamma * step.T, (1 - self.gamma) * p0
        )
        self.d_expert = (d_s[:, None] * pi).flatten()  # occupancy d_E(s, a), rows' order
        self.d_data = torch.full((S * A,), 1 / (S * A), dtype=f64)
        eye = torch.eye(S, dtype=f64)
        self.batch = _rows(eye[self.s], None, eye[self.next])

    def marginal(self, d: torch.Tensor, kind: str) -> torch.Tensor:
        """d over the discriminator's input: (s, a), s' or (s, s')."""
        if kind == "sa":
            return d
        index = self.next if kind == "s" else self.s * self.S + self.next
        return torch.zeros(self.S**2, dtype=d.dtype).index_add_(0, index, d)[index]

    def log_ratio(self, kind: str) -> torch.Tensor:
        """The optimal discriminator's logit log(rho_E / rho_D) on each row's input."""
        return torch.log(self.marginal(self.d_expert, kind) / self.marginal(self.d_data, kind))

    def flow_error(self, d: torch.Tensor) -> float:
        """max_s |sum_a d(s, a) - (1 - gamma) p0(s) - gamma sum P(s | s~, a~) d(s~, a~)|."""
        out = torch.zeros(self.S, dtype=d.dtype).index_add_(0, self.s, d)
        into = torch.zeros(self.S, dtype=d.dtype).index_add_(0, self.next, d)
        return float((out - (1 - self.gamma) * self.p0 - self.gamma * into).abs().max())


def solve_dual(chain: Chain, kind: str, alpha: float, divergence: str) -> torch.Tensor:
    """The dual's minimiser over a table nu (LBFGS); the occupancy w d_D it implies."""
    table = torch.zeros(chain.S, dtype=torch.float64, requires_grad=True)
    reward = chain.log_ratio(kind)

    def nu(obs: torch.Tensor) -> torch.Tensor:
        return (obs @ table)[:, None]

    def loss() -> torch.Tensor:
        e = advantage(nu, chain.batch, reward, chain.gamma)
        return dual_loss(table[:1], e, chain.gamma, alpha, divergence)

    opt = torch.optim.LBFGS(
        [table], max_iter=500, tolerance_grad=1e-12, line_search_fn="strong_wolfe"
    )

    def closure() -> torch.Tensor:
        opt.zero_grad()
        value = loss()
        value.backward()
        return value

    for _ in range(3):
        opt.step(closure)
    e = advantage(nu, chain.batch, reward, chain.gamma).detach()
    return dice_weights(e, alpha, divergence) * chain.d_data


@pytest.mark.parametrize("module, kind", [(demodice, "sa"), (lobsdice, "ss")])
def test_kl_dice_recovers_the_experts_distribution_on_a_finite_mdp(module: Any, kind: str) -> None:
    """alpha = 0: the dual's optimum is the expert's occupancy over the method's input;
    with alpha > 0 it stays an occupancy, between the expert's and the data's."""
    chain = Chain()
    assert module.DUAL.divergence == "kl"
    d = solve_dual(chain, kind, 0.0, "kl")
    expert = chain.marginal(chain.d_expert, kind)
    assert float((chain.marginal(d, kind) - expert).abs().max()) < 1e-6
    assert chain.flow_error(d) < 1e-6
    for alpha in (0.05, 0.1):
        d = solve_dual(chain, kind, alpha, "kl")
        error = float((chain.marginal(d, kind) - expert).abs().max())
        assert chain.flow_error(d) < 1e-6 and 1e-4 < error < 0.02, (alpha, error)
    assert module.DUAL.alpha in (0.0, 0.1)  # the authors' code: LfD 0, LfO 0.1


def test_smodice_duals_give_an_occupancy_closer_to_the_experts_states() -> None:
    """SMODICE's duals with its state reward log(rho_E(s') / rho_D(s')). KL (the default,
    as the authors' code for observations) and chi2_plus (the conjugate on x >= 0) are
    exactly flow-constrained duals: their optima are occupancies. The authors' unclipped
    chi2 lets the optimum's d go negative, so its clipped weights are only nearly an
    occupancy (flow error 0.015 here). All three move the data's distribution towards the
    expert's states; none recovers them exactly (SMODICE optimises a bound)."""
    chain = Chain()
    assert smodice.DUAL.divergence == "kl" and smodice.DUAL.alpha == 0.0

    def state_gap(x: torch.Tensor) -> float:
        per_state = torch.zeros(chain.S, dtype=x.dtype).index_add_(0, chain.s, x - chain.d_expert)
        return float(per_state.abs().sum() / 2)

    for divergence, flow_tolerance, shrink in (
        ("kl", 1e-5, 0.7),  # 0.078 against the data's 0.131
        ("chi2_plus", 1e-6, 0.5),
        ("chi2", 0.03, 0.5),
    ):
        d = solve_dual(chain, "s", 0.0, divergence)
        assert bool((d >= 0).all())
        assert chain.flow_error(d) < flow_tolerance, (divergence, chain.flow_error(d))
        gap = state_gap(d)
        assert gap < shrink * state_gap(chain.d_data), (divergence, gap)
    # f*_+ is the conjugate of (x - 1)^2 / 2 on x >= 0, its derivative the weight.
    y = torch.linspace(-3, 3, 61, requires_grad=True)
    x = torch.linspace(0, 5, 501)
    brute = (y.detach()[:, None] * x - 0.5 * (x - 1) ** 2).max(1).values
    restricted = chi2_conjugate(y, restricted=True)
    torch.testing.assert_close(restricted, brute, atol=1e-4, rtol=0)
    (grad,) = torch.autograd.grad(restricted.sum(), y)
    torch.testing.assert_close(grad, dice_weights(y, 0.0, "chi2_plus"))
    # The unclipped form: the conjugate over all reals, whose gradient stays y + 1 < 0
    # below -1 (those rows still move nu); equal to f*_+ from y = -1 on.
    x = torch.linspace(-5, 5, 1001)
    brute = (y.detach()[:, None] * x - 0.5 * (x - 1) ** 2).max(1).values
    torch.testing.assert_close(chi2_conjugate(y), brute, atol=1e-4, rtol=0)
    (grad,) = torch.autograd.grad(chi2_conjugate(y).sum(), y)
    torch.testing.assert_close(grad, y.detach() + 1)
    above = y.detach() >= -1
    torch.testing.assert_close(chi2_conjugate(y.detach())[above], restricted.detach()[above])


def test_effective_share_of_weights() -> None:
    """Uniform weights use every row, one-hot weights one row, k equal weights k rows."""
    assert effective_share(torch.full((8,), 3.0)) == pytest.approx(1.0)
    assert effective_share(torch.eye(8)[2]) == pytest.approx(1 / 8)
    assert effective_share(torch.tensor([2.0, 2.0, 0.0, 0.0])) == pytest.approx(0.5)


def test_iqlearn_q_ranks_the_expert_action_first_on_a_chain() -> None:
    """6 states, actions left / right; the expert always goes right (and stays at the end).
    Minibatch: the expert's rows and every (s, a) once; V(s) = t logsumexp(Q(s, .) / t)."""
    # L(Q) written out on 3 rows (2 critics), the first an expert row.
    q3, v3 = torch.tensor([[1.0, 2.0], [0.5, 0.0], [-1.0, 1.0]]), torch.tensor([1.0, 0.2, 0.4])
    v_next, discount = torch.tensor([0.5, 1.0, 2.0]), torch.tensor([1.0, 1.0, 0.0])
    y = 0.9 * discount * v_next
    r = q3 - y[:, None]
    written = -r[0].mean() + (v3 - y).mean() + (r**2).mean() / (4 * 0.5)
    loss3 = iq_loss(q3, v3, v_next, discount, torch.tensor([True, False, False]), 0.9, 0.5)
    torch.testing.assert_close(loss3, written)
    S, temperature = 6, 0.1
    expert_s = torch.tensor([0, 1, 2, 3, 4, 5, 5, 5])
    s = torch.cat([expert_s, torch.arange(S).repeat_interleave(2)])
    a = torch.cat([torch.ones(8, dtype=torch.long), torch.arange(2).repeat(S)])
    s_next = (s + 2 * a - 1).clamp(0, S - 1)
    expert = torch.arange(len(s)) < 8
    q = torch.zeros(S, 2, requires_grad=True)
    opt = torch.optim.Adam([q], lr=0.05)
    for _ in range(1500):
        v = temperature * torch.logsumexp(q / temperature, -1)
        loss = iq_loss(q[s, a][:, None], v[s], v[s_next], torch.ones(len(s)), expert, 0.9, 0.5)
        opt.zero_grad()
        loss.backward()
        opt.step()
    assert (q.argmax(-1) == 1).all(), q
    # The implied reward Q(s, a) - gamma V(s') is higher on the expert's moves.
    v = temperature * torch.logsumexp(q / temperature, -1)
    implied = (q[s, a] - 0.9 * v[s_next]).detach()
    assert implied[8:][a[8:] == 1][:-1].min() > implied[8:][a[8:] == 0].max()


def test_dice_configs_refuse_unknown_fields_and_divergences() -> None:
    with pytest.raises(FbilError, match="unknown config field"):
        config_from_dict(DualConfig, {"divergnce": "kl"})
    with pytest.raises(FbilError, match="unknown divergence 'js'"):
        DualConfig(divergence="js")
    with pytest.raises(FbilError, match="unknown initial_states 'uniform'; valid: dataset, demos"):
        DualConfig(initial_states="uniform")
