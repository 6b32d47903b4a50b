"""The offline-IL baselines: BC's fit, the TD3IL and ORIL reward labels on hand-built
batches, and every baseline end to end at smoke size through `fbil evaluate` and the
benchmark grid, on the maze fixture."""

import dataclasses
import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import torch
from torch import nn

from fbil.baselines.bc import BCConfig, train_bc
from fbil.baselines.common import Transitions, demo_transitions
from fbil.baselines.offline_td3 import MixedSampler
from fbil.baselines.oril import Discriminator, discriminator_loss
from fbil.baselines.td3il import labels
from fbil.data import load_dataset
from fbil.errors import FbilError
from fbil.evaluation.benchmark import make_jobs, run_job
from fbil.imitation import Demos, from_arrays

BASELINES = ("bc", "td3il", "oril", "oril_o", "oril_oo")
BASELINES += ("dwbc", "sqil", "demodice", "smodice", "lobsdice", "iqlearn")


def fbil(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "fbil", *args], capture_output=True, text=True, timeout=300
    )


@pytest.mark.parametrize("loss", ["mse", "gaussian"])
def test_bc_recovers_a_linear_experts_actions(loss: str) -> None:
    rng = np.random.default_rng(0)
    w = np.array([[0.4, -0.2, 0.1, 0.0], [0.0, 0.3, -0.3, 0.2]], np.float32)
    obs = [rng.uniform(-1, 1, (51, 4)).astype(np.float32) for _ in range(8)]
    demos = from_arrays(obs, [o[:-1] @ w.T for o in obs])
    rows = demo_transitions(demos)
    assert rows.action is not None
    cfg = BCConfig(steps=1500, hidden=64, batch_size=128, lr=1e-3, loss=loss)
    policy = train_bc(rows.obs, rows.action, cfg, seed=0)
    test = rng.uniform(-0.9, 0.9, (200, 4)).astype(np.float32)
    error = np.abs(policy.act(test) - test @ w.T)
    assert error.mean() < 0.03 and error.max() < 0.15, (error.mean(), error.max())


def _batch(n_data: int, n_expert: int) -> Transitions:
    gen = torch.Generator().manual_seed(0)
    n = n_data + n_expert
    return Transitions(
        torch.randn(n, 4, generator=gen),
        torch.rand(n, 2, generator=gen) * 2 - 1,
        torch.randn(n, 4, generator=gen),
        torch.ones(n),
        torch.arange(n) >= n_data,
    )


def test_td3il_rewards_expert_rows_1_and_dataset_rows_0(fixture_data: Path) -> None:
    batch = _batch(5, 3)
    assert labels(batch).tolist() == [0.0] * 5 + [1.0] * 3
    dataset = load_dataset(fixture_data)
    expert = _batch(0, 7)
    gen = torch.Generator().manual_seed(1)
    fixed = MixedSampler(dataset, expert, 512, 0.002, gen)()  # Table 2's ratio: 1 row
    assert len(fixed) == 512 and int(fixed.expert.sum()) == 1
    assert torch.equal(labels(fixed), fixed.expert.float())
    # The dataset's rows are its transitions (obs[j-1], action[j], obs[j]).
    j = dataset.next_index
    data_rows = ~fixed.expert
    obs = dataset.observation[j - 1]
    match = (obs[None, :, :] == fixed.obs[data_rows][:, None, :].numpy()).all(-1).any(-1)
    assert match.all()
    union = MixedSampler(dataset, expert, 512, None, gen)()  # 7 of ~4000 rows: ~1 a batch
    assert len(union) == 512 and int(union.expert.sum()) <= 8


def _linear(disc: Discriminator, width: int) -> torch.Tensor:
    """Replace D's network by a known linear logit w.x + 0.5; return w."""
    w = torch.linspace(-0.5, 0.5, width)
    layer = nn.Linear(width, 1)
    with torch.no_grad():
        layer.weight.copy_(w[None])
        layer.bias.fill_(0.5)
    disc.net = nn.Sequential(layer)
    return w


@pytest.mark.parametrize("kind, width", [("sa", 6), ("s", 4), ("ss", 8)])
def test_oril_reward_is_log_of_d_plus_1_on_the_variants_input(kind: str, width: int) -> None:
    stats = torch.stack([torch.full((4,), 0.1), torch.full((4,), 2.0)])
    disc = Discriminator(kind, stats, act_dim=2, hidden=16)
    batch = _batch(4, 2)
    norm_obs, norm_next = (batch.obs - 0.1) / 2.0, (batch.next_obs - 0.1) / 2.0
    assert batch.action is not None
    expected_x = {
        "sa": torch.cat([norm_obs, batch.action], -1),
        "s": norm_next,
        "ss": torch.cat([norm_obs, norm_next], -1),
    }[kind]
    torch.testing.assert_close(disc.features(batch), expected_x)
    w = _linear(disc, width)
    d = torch.sigmoid(expected_x @ w + 0.5)
    torch.testing.assert_close(disc.reward(batch), torch.log(d + 1))
    # BCE (expert 1, dataset 0); a linear logit's input gradient is w everywhere.
    x = disc.features(batch)
    gen = torch.Generator().manual_seed(0)
    bare = discriminator_loss(disc, x[4:], x[:2], 0.0, gen)
    bce = (
        -torch.log(torch.sigmoid(x[4:] @ w + 0.5)).mean()
        - torch.log(1 - torch.sigmoid(x[:2] @ w + 0.5)).mean()
    )
    torch.testing.assert_close(bare, bce)
    penalised = discriminator_loss(disc, x[4:], x[:2], 10.0, gen)
    torch.testing.assert_close(penalised - bare, 10.0 * (w.norm() - 1) ** 2)


def test_every_baseline_runs_end_to_end_from_the_command_line(
    smoke_model_dir: Path, demos_dir: Path, fixture_data: Path
) -> None:
    """FB-IL and baselines in one call: one rollout, every results entry with its family."""
    methods = ",".join(("erfb", *BASELINES))
    res = fbil(
        *("evaluate", str(smoke_model_dir), str(demos_dir / "square.npz")),
        *("--methods", methods, "--data", str(fixture_data), "--budget", "smoke"),
        *("--episodes", "1", "--json"),
    )
    assert res.returncode == 0, res.stderr
    out = json.loads(res.stdout)["methods"]
    assert list(out) == ["erfb", *BASELINES]
    assert out["erfb"]["family"] == "fb-il"
    for name in BASELINES:
        assert out[name]["family"] == "offline-il" and out[name]["seconds"] > 0
        assert np.isfinite(out[name]["score"])
    # Without an FB-IL method the model is never read.
    res = fbil(
        *("evaluate", "no-model", str(demos_dir / "square.npz"), "--methods", "bc"),
        *("--budget", "smoke", "--episodes", "1"),
    )
    assert res.returncode == 0, res.stderr
    assert any(line.startswith("bc ") for line in res.stdout.splitlines())


def test_benchmark_rows_carry_family_budget_and_config(demos_dir: Path, fixture_data: Path) -> None:
    jobs = make_jobs(
        None, demos_dir, "point_mass_maze", ["square"], ["bc", "td3il"], 1, 1, 1,
        data=fixture_data, budget="smoke",
    )  # fmt: skip
    bc, td3il = (run_job(job) for job in jobs)
    assert bc["family"] == td3il["family"] == "offline-il"
    assert bc["data"] is None and td3il["data"] == str(fixture_data)
    assert bc["budget"] == td3il["budget"] == "smoke"
    assert td3il["config"]["expert_ratio"] == 0.002 and len(td3il["returns"]) == 1
    # Which dataset (a content digest) and which kind of CPU each line was made with.
    assert bc["data_digest"] is None
    assert td3il["data_digest"] == load_dataset(fixture_data).digest()
    assert bc["machine"] == td3il["machine"] and bc["machine"].strip()
    # The learner's last update, with the largest value its 0/1 rewards allow at the
    # maze's gamma 0.99 and whether its critic ran past twice that.
    assert td3il["fit"]["q_bound"] == pytest.approx(100.0) and td3il["fit"]["q_diverged"] == 0.0
    assert "q_bound" not in bc["fit"]


@pytest.mark.parametrize(
    "demo, args, message",
    [
        ("square_free.npz", ["--methods", "bc"], "bc needs expert actions"),
        ("square.npz", ["--methods", "td3il"], "pass --data"),
        ("square.npz", ["--methods", "oril_o", "--data", "{data}", "--budget", "gpu"], "budget"),
    ],
)
def test_baseline_mistakes_are_one_line_errors(
    demo: str, args: list[str], message: str, demos_dir: Path, fixture_data: Path
) -> None:
    args = [a.format(data=fixture_data) for a in args]
    res = fbil("evaluate", "no-model", str(demos_dir / demo), *args, "--episodes", "1")
    lines = res.stderr.strip().splitlines()
    assert res.returncode == 2 and len(lines) == 1 and message in lines[0], res.stderr


def test_a_dataset_of_another_domain_is_refused(demos_dir: Path, fixture_data: Path) -> None:
    demos = Demos.load(demos_dir / "square.npz")
    walker = demos_dir / "walker.npz"
    Demos(demos.trajectories, {**demos.metadata, "domain": "walker", "task": "walk"}).save(walker)
    res = fbil(
        *("evaluate", "no-model", str(walker), "--methods", "td3il"),
        *("--data", str(fixture_data), "--budget", "smoke"),
    )
    lines = res.stderr.strip().splitlines()
    assert res.returncode == 2 and len(lines) == 1 and "not walker" in lines[0], res.stderr


def test_demodice_learns_on_the_union_of_dataset_and_demos(
    demos_dir: Path, fixture_data: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """DemoDICE's D holds the demonstrations too (the authors' code); SMODICE's, from
    action-free demos, the dataset alone. Rows are drawn uniformly over D."""
    from fbil.baselines import dice
    from fbil.baselines.demodice import DUAL

    seen: list[torch.Tensor] = []
    update = dice.DiceLearner.update

    def spy(
        self: dice.DiceLearner,
        batch: Transitions,
        starts: torch.Tensor,
        expert: Transitions | None = None,
    ) -> dict[str, float]:
        seen.append(batch.expert)
        return update(self, batch, starts, expert)

    monkeypatch.setattr(dice.DiceLearner, "update", spy)
    demos, data = Demos.load(demos_dir / "square.npz"), load_dataset(fixture_data)
    cfg = dice.smoke(DUAL)
    dice.train_dice("demodice", "sa", demos, data, cfg, 10.0, 0, union=True)
    share = float(torch.cat(seen).float().mean())
    n_demo = len(demo_transitions(demos))
    expected = n_demo / (n_demo + int(data.num_transitions))
    assert abs(share - expected) < 0.1, (share, expected)
    seen.clear()
    dice.train_dice("smodice", "s", demos, data, cfg, 10.0, 0)
    assert not bool(torch.cat(seen).any())


def test_dice_bounded_reward_and_nu_gradient_penalty(demos_dir: Path, fixture_data: Path) -> None:
    """The DemoDICE code's options: r = -log(1 / (D + eps) - 1 + eps) equals the logit at
    eps 0 and stays within [log eps, -2 log eps]; nu's gradient penalty enters the loss."""
    from dataclasses import replace

    from fbil.baselines import dice
    from fbil.baselines.demodice import DUAL

    logits = torch.tensor([-40.0, -3.0, 0.0, 3.0, 40.0])
    assert torch.equal(dice.dice_reward(logits), logits)
    bounded = dice.dice_reward(logits, 1e-3)
    assert abs(float(bounded[2])) < 1e-2 and abs(float(bounded[1]) + 3.0) < 0.05
    assert float(bounded.min()) > math.log(1e-3) - 1e-3
    assert float(bounded.max()) < -2 * math.log(1e-3) + 0.1  # float32 cancellation
    demos, data = Demos.load(demos_dir / "square.npz"), load_dataset(fixture_data)
    cfg = dice.smoke(replace(DUAL, nu_grad_penalty=1e-4, reward_eps=1e-3))
    policy = dice.train_dice("demodice", "sa", demos, data, cfg, 10.0, 0, union=True)
    assert math.isfinite(policy.info["nu_loss"])
    learner = dice.DiceLearner(
        dice.train_discriminator("sa", demos, data, cfg.discriminator, 0), data, cfg.dual
    )
    expert = demo_transitions(demos)
    batch = expert.select(torch.arange(8))
    assert float(learner.grad_penalty(batch, expert).detach()) > 0


def test_dice_reward_fn_replaces_the_discriminator(demos_dir: Path, fixture_data: Path) -> None:
    """`reward_fn` (the diagnostics' true-reward oracle) is the reward the dual sees: the
    rows' dataset indices reach it, and its values, not the log-ratio, enter e."""
    from fbil.baselines import dice
    from fbil.baselines.smodice import DUAL

    demos, data = Demos.load(demos_dir / "square.npz"), load_dataset(fixture_data)
    cfg = dice.smoke(DUAL)
    seen: list[torch.Tensor] = []

    def reward_fn(batch: Transitions) -> torch.Tensor:
        assert batch.index is not None
        seen.append(batch.index)
        return torch.full((len(batch),), 7.0)

    policy = dice.train_dice("smodice", "s", demos, data, cfg, 10.0, 0, reward_fn=reward_fn)
    assert len(seen) == cfg.dual.steps and policy.info["r"] == 7.0
    assert int(torch.cat(seen).max()) < int(data.num_transitions)
    plain = dice.train_dice("smodice", "s", demos, data, cfg, 10.0, 0)
    assert plain.info["r"] != 7.0


def test_offline_td3_bc_alpha_reaches_the_actor_loss() -> None:
    """`OfflineTD3Config.bc_alpha` (TD3+BC, the ORIL/OTR reference code's policy loss) reaches
    TD3: with it the actor loss is -lambda Q + |pi(s) - a|^2 (>= -alpha), without it -Q."""
    from fbil.agents.td3 import TD3
    from fbil.baselines.offline_td3 import OfflineTD3Config

    cfg = OfflineTD3Config(hidden=32, batch_size=16, bc_alpha=2.5).td3("point_mass_maze")
    assert cfg.bc_alpha == 2.5 and OfflineTD3Config().td3("walker").bc_alpha is None
    obs, act = torch.randn(16, 4), torch.rand(16, 2) * 2 - 1
    with_bc = float(TD3(4, 2, cfg, seed=0).actor_loss(obs, act).detach())
    plain = TD3(4, 2, OfflineTD3Config(hidden=32).td3("point_mass_maze"), seed=0)
    q = float(-plain.actor_loss(obs, act).detach())
    assert with_bc >= -2.5 - 1e-5 and abs(with_bc - float(-q)) > 1e-6


def test_offline_td3_target_clamp_bounds_the_critics_regression_target() -> None:
    """`OfflineTD3Config.target_min/max` reach TD3: with rewards of 100 the TD target
    stays at the clamp's top, so the critic loss is that of regressing onto 50."""
    from fbil.agents.td3 import TD3
    from fbil.baselines.offline_td3 import OfflineTD3Config

    clamped = OfflineTD3Config(hidden=32, target_min=0.0, target_max=50.0).td3("cheetah")
    assert (clamped.target_min, clamped.target_max) == (0.0, 50.0)
    assert OfflineTD3Config().td3("cheetah").target_max is None
    obs, act, eps = torch.randn(16, 4), torch.rand(16, 2) * 2 - 1, torch.zeros(16, 2)
    rew, disc = torch.full((16,), 100.0), torch.ones(16)
    agent = TD3(4, 2, clamped, seed=0)
    loss, q = agent.critic_loss(obs, act, rew, obs, disc, eps)
    assert abs(float(loss.detach()) - 2 * float(((q - 50.0) ** 2).mean())) < 1.0


def test_offline_td3_policy_delay_sets_how_often_the_actor_and_targets_move() -> None:
    """`OfflineTD3Config.policy_delay` reaches TD3: at 1 the actor and the targets step
    with every critic step (Meta's DDPG-style agent), at 2 every second one (TD3); 0 is
    refused in one line, also as a budget setting."""
    from fbil.agents.td3 import TD3
    from fbil.baselines.offline_td3 import OfflineTD3Config

    obs, act = torch.randn(16, 4), torch.rand(16, 2) * 2 - 1
    rew, disc = torch.rand(16), torch.ones(16)
    for delay in (1, 2):
        cfg = OfflineTD3Config(hidden=32, batch_size=16, policy_delay=delay).td3("point_mass_maze")
        agent = TD3(4, 2, cfg, seed=0)
        before = [p.detach().clone() for p in agent.critic_targets.parameters()]
        first = agent.update(obs, act, rew, obs, disc)
        moved = [
            not torch.equal(a, b)
            for a, b in zip(before, agent.critic_targets.parameters(), strict=True)
        ]
        assert ("actor_loss" in first) == any(moved) == (delay == 1)
        metrics = [first, *(agent.update(obs, act, rew, obs, disc) for _ in range(3))]
        assert sum("actor_loss" in m for m in metrics) == 4 // delay
    with pytest.raises(FbilError, match="policy_delay must be >= 1"):
        OfflineTD3Config(policy_delay=0).td3("point_mass_maze")
    from fbil.imitators import FitContext, get_imitator

    config = get_imitator("td3il").settings(FitContext(budget="cpu,td3.policy_delay=1"))
    assert config["config"]["td3"]["policy_delay"] == 1


def test_offline_td3_on_step_sees_every_update_and_the_final_agent(fixture_data: Path) -> None:
    """`train_offline_td3(on_step=...)` (a diagnostic's budget curve within one run) is
    called after updates 1..steps with the agent being trained, and changes nothing."""
    from fbil.baselines.offline_td3 import OfflineTD3Config, train_offline_td3

    dataset = load_dataset(fixture_data)
    cfg = OfflineTD3Config(steps=5, hidden=16, batch_size=32)
    seen: list[int] = []
    agents: set[int] = set()

    def on_step(t: int, agent: object) -> None:
        seen.append(t)
        agents.add(id(agent))

    agent, info = train_offline_td3(dataset, labels, cfg, 0, on_step=on_step)
    assert seen == [1, 2, 3, 4, 5] and agents == {id(agent)}
    _, plain = train_offline_td3(dataset, labels, cfg, 0)
    assert plain == info  # the same seed gives the same last update with or without it


def test_offline_td3_diagnostic_switches_reach_the_agent(fixture_data: Path) -> None:
    """`td3.standardize=false` keeps the inputs raw (mean 0, std 1 stats) and
    `td3.actor_q=min_noisy` reaches TD3's config, both also as budget settings."""
    from fbil.baselines.offline_td3 import OfflineTD3Config, train_offline_td3
    from fbil.imitators import FitContext, get_imitator

    dataset = load_dataset(fixture_data)
    cfg = OfflineTD3Config(steps=2, hidden=16, batch_size=32)
    raw, _ = train_offline_td3(dataset, labels, dataclasses.replace(cfg, standardize=False), 0)
    assert torch.equal(raw.obs_stats, torch.stack([torch.zeros(4), torch.ones(4)]))
    scaled, _ = train_offline_td3(dataset, labels, cfg, 0)
    assert not torch.equal(scaled.obs_stats, raw.obs_stats)
    assert OfflineTD3Config(actor_q="min_noisy").td3("point_mass_maze").actor_q == "min_noisy"
    spec = "cpu,td3.standardize=false,td3.actor_q=min_noisy"
    config = get_imitator("td3il").settings(FitContext(budget=spec))["config"]["td3"]
    assert config["standardize"] is False and config["actor_q"] == "min_noisy"


def test_sac_oracle_hook_and_no_expert_rows(fixture_data: Path) -> None:
    """`train_sac(expert=None, on_step=...)` (the true-reward oracle of the diagnosis
    script) samples dataset rows only, calls the hook after updates 1..steps, and gives
    the same last update as a run without the hook."""
    from fbil.baselines.sac import SAC, SACConfig, train_sac

    dataset = load_dataset(fixture_data)
    cfg = SACConfig(steps=4, hidden=16, batch_size=32)
    seen: list[int] = []
    experts: list[int] = []

    def update(agent: SAC, batch: Transitions) -> dict[str, float]:
        experts.append(int(batch.expert.sum()))
        return agent.update(batch, torch.ones(len(batch.obs)))

    agents: set[int] = set()

    def on_step(t: int, agent: SAC) -> None:
        seen.append(t)
        agents.add(id(agent))

    agent, info = train_sac(dataset, update, cfg, 0, None, 0.0, on_step)
    assert seen == [1, 2, 3, 4] and experts == [0, 0, 0, 0] and agents == {id(agent)}
    _, plain = train_sac(dataset, update, cfg, 0, None, 0.0)
    assert plain == info


def test_time_to_policy_projects_each_baseline_from_small_scales(
    fixture_data: Path, demos_dir: Path
) -> None:
    """benchmarks/time_to_policy.py --baselines: the line through the medians at two scales
    is exact on a line, and each trained baseline gets medians and a projection at scale 1;
    a method with nothing to train (goal_td3) is left out."""
    from tests.script_module import SCRIPTS, load_script

    bench = load_script("time_to_policy", SCRIPTS.parent / "benchmarks")
    assert bench.line_through([0.01, 0.02, 0.04], [3.0, 5.0, 9.0]) == pytest.approx((1.0, 200.0))
    with pytest.raises(ValueError):
        bench.line_through([0.5, 0.5], [1.0, 2.0])
    demos = Demos.load(demos_dir / "square.npz").select([0])
    out = bench.baseline_timings(
        ["bc", "goal_td3"], demos, load_dataset(fixture_data), "smoke", [1.0, 2.0], 1
    )
    assert list(out) == ["bc"]
    row = out["bc"]
    assert list(row["median_seconds"]) == ["1.0", "2.0"] and row["budget"] == "smoke"
    slope = row["median_seconds"]["2.0"] - row["median_seconds"]["1.0"]
    assert row["projected_seconds"] == pytest.approx(row["median_seconds"]["1.0"])
    assert row["fixed_seconds"] == pytest.approx(row["median_seconds"]["1.0"] - slope)
    # `auto` resolves to the method's measured budget on the demo's domain (the maze: cpu)
    auto = bench.baseline_timings(
        ["bc"], demos, load_dataset(fixture_data), "auto", [1e-4, 2e-4], 1
    )
    assert auto["bc"]["budget"] == "cpu"
