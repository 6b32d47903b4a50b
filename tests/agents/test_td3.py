"""TD3's bf16 path computes the fp32 update up to bf16 rounding of the hidden layers."""

import pytest
import torch

from fbil.agents.td3 import TD3, TD3Config
from fbil.errors import FbilError


def _batch(seed: int) -> tuple[torch.Tensor, ...]:
    g = torch.Generator().manual_seed(seed)
    n = 64
    return (
        torch.randn(n, 5, generator=g),
        torch.rand(n, 2, generator=g) * 2 - 1,
        torch.rand(n, generator=g) * 10,
        torch.randn(n, 5, generator=g),
        torch.full((n,), 0.98),
    )


def test_bf16_losses_and_updates_stay_within_a_percent_of_fp32() -> None:
    fp32 = TD3(5, 2, TD3Config(hidden=64), seed=0)
    bf16 = TD3(5, 2, TD3Config(hidden=64, precision="bf16"), seed=0)
    for step in range(6):
        a, b = fp32.update(*_batch(step)), bf16.update(*_batch(step))
        assert b["critic_loss"] == pytest.approx(a["critic_loss"], rel=0.02)
        assert b["q"] == pytest.approx(a["q"], rel=0.02, abs=1e-3)
    obs = _batch(99)[0]
    act_a, act_b = fp32.act(obs.numpy()), bf16.act(obs.numpy())
    assert abs(act_a - act_b).max() < 0.02
    # Q keeps its resolution near large values: the last layer runs in fp32.
    big = torch.full((1, 5), 3.0)
    q = bf16._q(bf16.critics, big, torch.zeros(1, 2))
    assert q.dtype == torch.float32


def test_unknown_precision_is_refused() -> None:
    with pytest.raises(FbilError, match="valid: fp32, bf16"):
        TD3Config(precision="fp16")  # type: ignore[arg-type]


def test_min_noisy_actor_loss_is_the_smoothed_minimum_of_both_critics() -> None:
    """actor_q="min_noisy" (Meta's offline agent): -min(Q1, Q2)(s, clip(pi(s) + clipped
    noise)), with the noise drawn from the agent's generator; "q1" is -Q1(s, pi(s))."""
    cfg = TD3Config(hidden=32, actor_q="min_noisy", policy_noise=0.2, noise_clip=0.3)
    agent = TD3(5, 2, cfg, seed=0)
    obs, act = _batch(1)[0], _batch(1)[1]
    g = torch.Generator()
    g.set_state(agent.gen.get_state())
    loss = float(agent.actor_loss(obs, act).detach())
    with torch.no_grad():
        pi = agent._pi(agent.actor, obs)
        noise = (torch.randn(pi.shape, generator=g) * 0.2).clamp(-0.3, 0.3)
        q = agent._q(agent.critics, obs, (pi + noise).clamp(-1, 1))
        assert loss == pytest.approx(float(-q.min(-1).values.mean()), rel=1e-5)
        q1 = float(-agent._q(agent.critics, obs, pi)[:, 0].mean())
    plain = TD3(5, 2, TD3Config(hidden=32), seed=0)
    assert float(plain.actor_loss(obs, act).detach()) == pytest.approx(q1, rel=1e-5)
    assert abs(loss - q1) > 1e-6
    with pytest.raises(FbilError, match="valid: q1, min_noisy"):
        TD3Config(actor_q="min")  # type: ignore[arg-type]


def test_the_td_target_is_clamped_to_the_set_range() -> None:
    """target_min / target_max clamp y = r + discount gamma min Q_target(s', a') before
    the critics regress it; unset, y is left alone."""
    obs, act, reward, nxt, disc = _batch(2)  # rewards in [0, 10)
    eps = torch.zeros_like(act)
    losses = {}
    for name, cfg in {
        "free": TD3Config(hidden=32),
        "clamped": TD3Config(hidden=32, target_min=0.0, target_max=1.0),
    }.items():
        agent = TD3(5, 2, cfg, seed=0)
        with torch.no_grad():
            nq = agent._q(
                agent.critic_targets, nxt, agent._smoothed(agent._pi(agent.actor_target, nxt), eps)
            )
            y = reward + disc * cfg.gamma * nq.min(-1).values
            y = y.clamp(0.0, 1.0) if name == "clamped" else y
            q = agent._q(agent.critics, obs, act)
            want = float(((q[:, 0] - y) ** 2).mean() + ((q[:, 1] - y) ** 2).mean())
        losses[name] = float(agent.critic_loss(obs, act, reward, nxt, disc, eps)[0].detach())
        assert losses[name] == pytest.approx(want, rel=1e-5)
    assert losses["free"] > 10 * losses["clamped"]  # rewards up to 10 against a cap of 1
    with pytest.raises(FbilError, match=r"target_min \(1.0\) must be below target_max"):
        TD3Config(target_min=1.0, target_max=1.0)


def _two_stream(precision: str = "fp32") -> TD3:
    # Inputs [s (3), c (2)]: the critic's flat input is [s, c, a].
    cfg = TD3Config(hidden=64, arch="two_stream", cond_dim=2, precision=precision)  # type: ignore[arg-type]
    return TD3(5, 2, cfg, seed=0)


def test_two_stream_critics_see_the_action_only_through_s_a_and_the_goal_through_s_c() -> None:
    """The paper's critic encodes (s, a) and (s, c) apart: with the (s, c) encoder's
    weights on c zeroed, Q no longer depends on c, and with the (s, a) encoder's weights on
    a zeroed, no longer on a (a wrong split of the flat input fails one of them)."""
    agent = _two_stream()
    critic = agent.critics[0]
    g = torch.Generator().manual_seed(0)
    s, c, a = torch.randn(8, 3, generator=g), torch.randn(8, 2, generator=g), torch.rand(8, 2)
    other_c, other_a = torch.randn(8, 2, generator=g), -a

    def q(c_: torch.Tensor, a_: torch.Tensor) -> torch.Tensor:
        return critic(torch.cat([s, c_, a_], -1))

    with torch.no_grad():
        assert not torch.allclose(q(c, a), q(other_c, a))
        assert not torch.allclose(q(c, a), q(c, other_a))
        critic.sc[0].weight[:, 3:] = 0  # the (s, c) encoder's weights on c
        assert torch.allclose(q(c, a), q(other_c, a))
        critic.sa[0].weight[:, 3:] = 0  # the (s, a) encoder's weights on a
        assert torch.allclose(q(c, a), q(c, other_a))


def test_two_stream_bf16_updates_stay_within_a_percent_of_fp32() -> None:
    fp32, bf16 = _two_stream(), _two_stream("bf16")
    for step in range(6):
        a, b = fp32.update(*_batch(step)), bf16.update(*_batch(step))
        assert b["critic_loss"] == pytest.approx(a["critic_loss"], rel=0.02)
    obs = _batch(99)[0]
    assert abs(fp32.act(obs.numpy()) - bf16.act(obs.numpy())).max() < 0.02
    q = bf16._q(bf16.critics, torch.full((1, 5), 3.0), torch.zeros(1, 2))
    assert q.dtype == torch.float32


def test_unknown_arch_and_a_two_stream_without_conditioning_are_refused() -> None:
    with pytest.raises(FbilError, match="valid: mlp, two_stream"):
        TD3Config(arch="wide")  # type: ignore[arg-type]
    with pytest.raises(FbilError, match="needs cond_dim >= 1"):
        TD3Config(arch="two_stream")
