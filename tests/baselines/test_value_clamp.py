"""`clamp_values`: the TD targets of the TD3- and SAC-based baselines clamped to the values
their rewards allow (cheetah's offline critics diverge without; docs/cheetah.md)."""

import dataclasses
import math
from pathlib import Path

import pytest
import torch

from fbil.baselines.common import Transitions, value_bounds, value_check
from fbil.baselines.offline_td3 import OfflineTD3Config
from fbil.baselines.sac import SAC, SACConfig
from fbil.data import load_dataset
from fbil.errors import FbilError
from fbil.imitation import Demos
from fbil.imitators import FitContext, get_imitator


def test_value_bounds_hold_every_discounted_return_of_the_range() -> None:
    assert value_bounds((0.0, 1.0), 0.98) == pytest.approx((0.0, 50.0))
    assert value_bounds((-1.0, 2.0), 0.9) == pytest.approx((-10.0, 20.0))
    assert value_bounds((0.2, 0.5), 0.9) == pytest.approx((0.0, 5.0))  # short episodes: 0
    assert value_bounds((0.0, 1.0), 0.9, bonus=0.5) == pytest.approx((0.0, 15.0))
    gen = torch.Generator().manual_seed(0)
    for _ in range(200):  # random rewards in [-1, 2] over random lengths stay inside
        n = int(torch.randint(1, 300, (1,), generator=gen))
        r = torch.rand(n, generator=gen) * 3 - 1
        ret = float((r * 0.9 ** torch.arange(n)).sum())
        assert -10.0 <= ret <= 20.0
    with pytest.raises(FbilError, match="low end"):
        value_bounds((1.0, 0.0), 0.98)


def test_offline_td3_clamp_values_derives_the_clamp_from_the_reward_range() -> None:
    cfg = OfflineTD3Config(clamp_values=True)
    spec = cfg.td3("cheetah", (0.0, math.log(2.0)))
    assert spec.target_min == 0.0 and spec.target_max == pytest.approx(math.log(2.0) / 0.02)
    assert OfflineTD3Config().td3("cheetah", (0.0, 1.0)).target_max is None  # off: no clamp
    with pytest.raises(FbilError, match="needs the method's reward range"):
        cfg.td3("cheetah")
    with pytest.raises(FbilError, match="not both"):
        OfflineTD3Config(clamp_values=True, target_max=50.0)


def _batch(n: int, obs_dim: int, act_dim: int) -> Transitions:
    gen = torch.Generator().manual_seed(1)
    obs = torch.randn(n, obs_dim, generator=gen)
    act = torch.rand(n, act_dim, generator=gen) * 2 - 1
    return Transitions(obs, act, obs, torch.ones(n), torch.zeros(n, dtype=torch.bool))


def test_sac_clamp_values_caps_the_soft_target_at_the_largest_soft_value(
    fixture_data: Path,
) -> None:
    """With the target critics pushed to 1e4, the clamped soft target is the bound
    (1 + alpha * act_dim * log 2) / (1 - gamma), so the critic regresses onto it; the
    plain one regresses onto ~1e4. A clamp without a reward range is refused."""
    dataset = load_dataset(fixture_data)
    batch = _batch(32, 4, 2)
    assert batch.action is not None
    losses: dict[bool, float] = {}
    for clamp in (False, True):
        agent = SAC(dataset, SACConfig(hidden=16, temperature=0.1, clamp_values=clamp), 0)
        agent.reward_range = (0.0, 1.0)
        with torch.no_grad():
            for net in agent.targets:
                net[-1].bias.fill_(1e4)  # type: ignore[index]
        q = agent.q(agent.critics, batch.obs, batch.action).detach()
        top = agent.target_max()
        assert (top is None) == (not clamp)
        losses[clamp] = agent.update(batch, torch.ones(32))["critic_loss"]
    assert top is not None and top == pytest.approx((1 + 0.1 * 2 * math.log(2)) / (1 - agent.gamma))
    assert losses[True] == pytest.approx(float(((q - top) ** 2).mean(0).sum()), rel=1e-3)
    assert losses[False] > 1e7
    agent.reward_range = None
    with pytest.raises(FbilError, match="needs the method's reward range"):
        agent.target_max()


@pytest.mark.parametrize(
    ("method", "setting", "top"),
    [
        ("td3il", "td3", 1.0),
        ("oril", "td3", math.log(2.0)),
        ("otr", "td3", None),  # its table's largest reward
        ("sqil", "sac", 1.0),
    ],
)
def test_each_method_clamps_to_its_own_reward_range(
    method: str,
    setting: str,
    top: float | None,
    demos_dir: Path,
    fixture_data: Path,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A budget's `td3.clamp_values=true` / `sac.clamp_values=true` reaches the learner with
    the method's own reward range: 0/1 labels, ORIL's log 2, OTR's relabeled table."""
    from fbil.baselines import offline_td3, sac

    seen: list[tuple[float, float] | None] = []
    td3_spec = offline_td3.OfflineTD3Config.td3
    sac_top = sac.SAC.target_max

    def spy_td3(self, domain, reward_range=None):  # type: ignore[no-untyped-def]
        seen.append(reward_range)
        return td3_spec(self, domain, reward_range)

    def spy_sac(self):  # type: ignore[no-untyped-def]
        seen.append(self.reward_range)
        return sac_top(self)

    monkeypatch.setattr(offline_td3.OfflineTD3Config, "td3", spy_td3)
    monkeypatch.setattr(sac.SAC, "target_max", spy_sac)
    demos = Demos.load(demos_dir / "square.npz")
    context = FitContext(
        dataset=load_dataset(fixture_data), budget=f"smoke,{setting}.clamp_values=true"
    )
    fitted = get_imitator(method).fit(demos, context)
    assert fitted.policy is not None and seen
    low, high = seen[0] or (None, None)
    assert low is not None and low >= 0.0
    if top is not None:
        assert high == pytest.approx(top)
    else:
        assert high is not None and 0.0 < high <= 5.0  # OTR's alpha


def test_iqlearn_refuses_a_clamp_it_has_no_reward_for(demos_dir: Path, fixture_data: Path) -> None:
    demos = Demos.load(demos_dir / "square.npz")
    context = FitContext(dataset=load_dataset(fixture_data), budget="smoke,sac.clamp_values=true")
    with pytest.raises(FbilError, match="IQ-Learn learns without a reward"):
        get_imitator("iqlearn").fit(demos, context)


def test_value_check_flags_a_critic_above_twice_its_bound() -> None:
    assert value_check({"q": 1693.9}, 50.0) == {"q": 1693.9, "q_bound": 50.0, "q_diverged": 1.0}
    assert value_check({"q": 60.0}, 50.0)["q_diverged"] == 0.0  # a little over: estimation
    assert value_check({"loss": 1.0}, 50.0) == {"loss": 1.0, "q_bound": 50.0}


def test_imitate_and_evaluate_note_a_runaway_critic(
    demos_dir: Path,
    fixture_data: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
    smoke_model_dir: Path,
) -> None:
    """A learner whose critic ran away (forced here: the check sees Q at 10x its bound)
    gets one `fbil: note:` line naming the method and the budget setting that clamps it;
    a sane one gets none."""
    from fbil.baselines import offline_td3
    from fbil.cli import main

    demos = str(demos_dir / "square.npz")
    common = ["--methods", "td3il", "--data", str(fixture_data), "--budget", "smoke"]
    assert main(["imitate", str(smoke_model_dir), demos, *common]) == 0
    assert "ran away" not in capsys.readouterr().err

    def runaway(info: dict[str, float], bound: float) -> dict[str, float]:
        return value_check({**info, "q": 10 * bound}, bound)

    monkeypatch.setattr(offline_td3, "value_check", runaway)
    assert main(["imitate", str(smoke_model_dir), demos, *common]) == 0
    evaluate = ["evaluate", str(smoke_model_dir), demos, *common, "--episodes", "1"]
    assert main(evaluate) == 0
    notes = [line for line in capsys.readouterr().err.splitlines() if "ran away" in line]
    assert len(notes) == 2 and all(n.startswith("fbil: note: td3il's critic") for n in notes)
    assert all("td3.clamp_values=true" in n for n in notes)


def test_goal_td3_clamp_values_bounds_the_goal_reward_values() -> None:
    """GOAL-TD3's 0/1 goal reward gives [0, 1/(1 - gamma)]; with explicit bounds it is
    refused."""
    from fbil.baselines.goal_td3 import GoalTD3Config, goal_preset

    cfg = dataclasses.replace(goal_preset("cheetah", "cpu"), clamp_values=True)
    assert (cfg.td3().target_min, cfg.td3().target_max) == pytest.approx((0.0, 50.0))
    assert goal_preset("cheetah", "cpu").td3().target_max is None
    with pytest.raises(FbilError, match="one or the other"):
        GoalTD3Config(clamp_values=True, target_max=50.0)
