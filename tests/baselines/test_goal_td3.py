"""GOAL-TD3: hindsight goals and the sparse reward, GOALFB's look-ahead schedule, a short
pre-training that orders goal-reaching values, exact resumption, the model folder and
its one-line errors, and `pretrain-goal` -> `evaluate --methods goal_td3` end to end."""

import dataclasses
import inspect
import json
import shutil
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import torch

from fbil.baselines.goal_model import CONFIG, GoalModel
from fbil.baselines.goal_td3 import (
    LOOKAHEAD,
    GoalTD3Trainer,
    GoalTrackingPolicy,
    HERSampler,
    goal_preset,
    goal_reward,
    goal_row,
    median_step,
)
from fbil.cli import main
from fbil.data import load_dataset
from fbil.errors import FbilError
from fbil.evaluation.benchmark import make_jobs, run_job
from fbil.imitation.api import imitate
from tests.baselines.test_baselines import fbil

SMALL = dataclasses.replace(goal_preset("point_mass_maze", "smoke"), checkpoint_seconds=1e9)


def test_hindsight_goals_are_future_states_of_the_same_episode(fixture_data: Path) -> None:
    dataset = load_dataset(fixture_data)
    cfg = dataclasses.replace(SMALL, batch_size=4096, her_ratio=1.0)
    batch = HERSampler(dataset, cfg, 0.01, torch.Generator().manual_seed(0))()
    row, goal = batch.row.numpy(), batch.goal_row.numpy()
    assert np.all(goal >= row) and np.all(goal <= dataset.state_episode_end[row])
    offset = goal - row  # Geometric(1 - gamma) - 1, clipped at the episode's end
    assert (offset == 0).mean() == pytest.approx(1 - cfg.gamma, abs=0.01)
    assert 0.5 * cfg.gamma / (1 - cfg.gamma) < offset.mean() < 1.2 * cfg.gamma / (1 - cfg.gamma)
    obs = dataset.observation
    np.testing.assert_array_equal(batch.next_obs.numpy(), obs[row])
    np.testing.assert_array_equal(batch.obs.numpy(), obs[row - 1])
    np.testing.assert_array_equal(batch.goal.numpy(), obs[goal])
    hit = np.linalg.norm(obs[row] - obs[goal], axis=1) <= 0.01
    np.testing.assert_array_equal(batch.reward.numpy(), hit.astype(np.float32))
    assert batch.reward[offset == 0].min() == 1 and 0 < hit.mean() < 1
    # HER ratio 0: goals are dataset states (never a reset row), mostly of other episodes.
    rand = HERSampler(dataset, dataclasses.replace(cfg, her_ratio=0.0), 0.01, batch_gen())()
    g = rand.goal_row.numpy()
    assert np.isin(g, dataset.next_index).all()
    other = dataset.state_episode_end[g] != dataset.state_episode_end[rand.row.numpy()]
    assert 0.6 < other.mean() < 0.9  # 3 episodes of 4 are others


def batch_gen() -> torch.Generator:
    return torch.Generator().manual_seed(1)


class Recorder:
    """A goal model that records the goals it is asked to reach."""

    config = type("C", (), {"epsilon": 0.01})()

    def __init__(self) -> None:
        self.goals: list[np.ndarray] = []

    def act(self, obs: Any, goal: Any) -> np.ndarray:
        self.goals.append(np.asarray(goal)[0])
        return np.zeros((len(obs), 2), np.float32)


def test_the_goal_distance_weighs_every_coordinate_by_its_spread(fixture_data: Path) -> None:
    """Standardised distances (the default) stop a wide coordinate from deciding alone
    whether a goal is reached; the radius is epsilon_steps median steps in that metric."""
    g = torch.tensor([[0.0, 0.0]])
    near_wide, near_narrow = torch.tensor([[5.0, 0.0]]), torch.tensor([[0.0, 0.5]])
    scale = torch.tensor([10.0, 0.1])
    assert goal_reward(near_wide, g, 1.0).item() == 0.0  # raw: 5 > 1
    assert goal_reward(near_narrow, g, 1.0).item() == 1.0
    assert goal_reward(near_wide, g, 1.0, scale).item() == 1.0  # 0.5 standard deviations
    assert goal_reward(near_narrow, g, 1.0, scale).item() == 0.0  # 5 standard deviations
    data = load_dataset(fixture_data)
    std = data.observation.std(0).clip(1e-3)
    assert median_step(data, std) != pytest.approx(median_step(data))
    cfg = dataclasses.replace(goal_preset("point_mass_maze", "smoke"), epsilon_steps=1.5)
    trainer = GoalTD3Trainer(cfg, data)
    assert trainer.mcfg.distance == "standardized"
    h = cfg.epsilon_horizon
    assert trainer.mcfg.epsilon == pytest.approx(1.5 * median_step(data, std, h), rel=1e-3)
    raw = GoalTD3Trainer(dataclasses.replace(cfg, distance="raw"), data)
    assert raw.mcfg.epsilon == pytest.approx(1.5 * median_step(data, None, h), rel=1e-6)
    batch = trainer.sampler()
    expected = goal_reward(batch.next_obs, batch.goal, trainer.mcfg.epsilon, trainer.sampler.scale)
    torch.testing.assert_close(batch.reward, expected)
    with pytest.raises(FbilError, match="unknown distance"):
        dataclasses.replace(cfg, distance="cosine")


def test_the_goal_at_step_t_is_the_demo_state_k_steps_ahead_as_goalfb() -> None:
    assert inspect.signature(imitate).parameters["lookahead"].default == LOOKAHEAD
    assert [goal_row(t, 6, 2) for t in range(7)] == [2, 3, 4, 5, 5, 5, 5]  # s_0..s_5
    states = np.arange(13, dtype=np.float32)[:, None].repeat(4, 1)  # s_t = (t, t, t, t)
    model = Recorder()
    policy = GoalTrackingPolicy(model, states, lookahead=LOOKAHEAD)  # type: ignore[arg-type]
    obs = np.zeros((3, 4), np.float32)
    assert policy.act(obs, step=0).shape == (3, 2)
    policy.act(obs, step=2)
    policy.act(obs, step=7)
    for _ in range(3):
        policy.act(obs)  # its own counter: steps 0, 1, 2
    policy.reset()
    policy.act(obs)
    seen = [int(g[0]) for g in model.goals]
    assert seen == [10, 12, 12, 10, 11, 12, 10]


def _q_order(model: GoalModel, dataset: Any) -> float:
    """Share of transitions (s, a, s') whose value for reaching s' (a reward now) beats
    that for reaching a random state of another episode."""
    gen = np.random.default_rng(0)
    j = dataset.next_index[gen.integers(0, dataset.num_transitions, 512)]
    far = (j + 1500) % len(dataset.observation)
    obs, act = dataset.observation[j - 1], dataset.action[j]
    near = model.q(obs, dataset.observation[j], act)
    other = model.q(obs, dataset.observation[far], act)
    return float((near > other).float().mean())


@pytest.mark.parametrize("arch", ["mlp", "two_stream"])
def test_a_short_pretraining_orders_goal_reaching_values(
    fixture_data: Path, tmp_path: Path, arch: str
) -> None:
    dataset = load_dataset(fixture_data)
    cfg = dataclasses.replace(SMALL, steps=300, hidden=64, batch_size=128, actor_lr=1e-3)
    cfg = dataclasses.replace(cfg, critic_lr=1e-3, arch=arch)
    trainer = GoalTD3Trainer(cfg, dataset)
    before = _q_order(trainer.model(), dataset)
    model = trainer.fit(tmp_path / "goal", progress=False)
    after = _q_order(model, dataset)
    assert after > 0.9 and after > before + 0.2, (before, after)
    loaded = GoalModel.load(tmp_path / "goal")  # the folder builds its arch's networks
    obs, goal = dataset.observation[:7], dataset.observation[100:101]
    assert loaded.config.arch == arch
    np.testing.assert_array_equal(loaded.act(obs, goal), model.act(obs, goal))


def _weights(model: GoalModel) -> dict[str, torch.Tensor]:
    return model.tensors()


def test_a_resumed_pretraining_equals_an_uninterrupted_one(
    fixture_data: Path, tmp_path: Path
) -> None:
    dataset = load_dataset(fixture_data)
    cfg = dataclasses.replace(SMALL, steps=40, log_every=10)
    whole = GoalTD3Trainer(cfg, dataset).fit(tmp_path / "whole", progress=False)
    GoalTD3Trainer(dataclasses.replace(cfg, steps=20), dataset).fit(
        tmp_path / "cut", progress=False
    )
    with pytest.raises(FbilError, match="already holds a goal model"):
        GoalTD3Trainer(cfg, dataset).fit(tmp_path / "cut", progress=False)
    with pytest.raises(FbilError, match=r"other settings \(hidden\)"):
        other = dataclasses.replace(cfg, hidden=16)
        GoalTD3Trainer(other, dataset).fit(tmp_path / "cut", resume=True, progress=False)
    other_data = tmp_path / "other"  # another sample of the recipe: one episode fewer
    shutil.copytree(fixture_data, other_data)
    sorted((other_data / "buffer").glob("*.npz"))[-1].unlink()
    with pytest.raises(FbilError, match=r"trained on data of digest \w+, this dataset's is"):
        GoalTD3Trainer(cfg, load_dataset(other_data)).fit(tmp_path / "cut", resume=True)
    resumed = GoalTD3Trainer(cfg, dataset).fit(tmp_path / "cut", resume=True, progress=False)
    assert resumed.metadata["data_digest"] == dataset.digest()
    a, b = _weights(whole), _weights(resumed)
    assert all(torch.equal(a[k], b[k]) for k in a)
    steps = [line.split(",")[0] for line in (tmp_path / "cut" / "goal_train_log.csv").open()]
    assert steps == ["step", "10", "20", "30", "40"]
    assert resumed.metadata["steps"] == 40 and resumed.config.epsilon == whole.config.epsilon


def test_a_checkpoint_from_before_a_setting_existed_resumes_at_its_default(
    fixture_data: Path, tmp_path: Path
) -> None:
    dataset = load_dataset(fixture_data)
    cfg = dataclasses.replace(SMALL, steps=10, log_every=10)
    trainer = GoalTD3Trainer(cfg, dataset)
    trainer.fit(tmp_path / "old", progress=False)
    state = trainer.state()
    for key in ("arch", "precision"):  # as a checkpoint saved before session 57
        del state["train_config"][key]
    GoalTD3Trainer(dataclasses.replace(cfg, steps=20), dataset).load(state, tmp_path)
    bf16 = dataclasses.replace(cfg, steps=20, precision="bf16")
    with pytest.raises(FbilError, match=r"other settings \(precision\)"):
        GoalTD3Trainer(bf16, dataset).load(state, tmp_path)


def test_the_goal_model_folder_loads_back_and_refuses_mismatches(
    fixture_data: Path, smoke_model_dir: Path, tmp_path: Path
) -> None:
    dataset = load_dataset(fixture_data)
    trainer = GoalTD3Trainer(dataclasses.replace(SMALL, steps=5), dataset)
    model = trainer.fit(tmp_path / "goal", progress=False)
    obs, goal = dataset.observation[:7], dataset.observation[100:101]
    np.testing.assert_array_equal(model.act(obs, goal), trainer.model().act(obs, goal))
    assert model.domain == "point_mass_maze" and model.config.epsilon > 0
    with pytest.raises(FbilError, match=r"no GOAL-TD3 model in .*expected goal_td3\.json"):
        GoalModel.load(tmp_path / "nothing")
    with pytest.raises(FbilError, match="it holds an FB model"):
        GoalModel.load(smoke_model_dir)
    body = json.loads((tmp_path / "goal" / CONFIG).read_text())
    for change, message in [
        ({"model": {**body["model"], "hidden": 16}}, "tensors do not match"),
        ({"model": {**body["model"], "width": 3}}, "unknown goal model config field"),
        ({"kind": "fb"}, "not a valid GOAL-TD3 model config"),
    ]:
        (tmp_path / "goal" / CONFIG).write_text(json.dumps({**body, **change}))
        with pytest.raises(FbilError, match=message) as err:
            GoalModel.load(tmp_path / "goal")
        assert "\n" not in str(err.value)


def test_goal_td3_runs_end_to_end_from_the_command_line(
    fixture_data: Path,
    demos_dir: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    out = tmp_path / "goal"
    res = fbil(
        *("pretrain-goal", "point_mass_maze", "--data", str(fixture_data)),
        *("--out", str(out), "--preset", "smoke", "--json"),
    )
    assert res.returncode == 0, res.stderr
    assert json.loads(res.stdout)["steps"] == 200
    demos = str(demos_dir / "square_free.npz")  # action-free: goal tracking needs states
    res = fbil(
        *("evaluate", "no-model", demos, "--methods", "goal_td3", "--goal-model", str(out)),
        *("--episodes", "1", "--json"),
    )
    assert res.returncode == 0, res.stderr
    result = json.loads(res.stdout)["methods"]["goal_td3"]
    assert result["family"] == "bfm" and result["principle"] == "goal tracking"
    assert result["seconds"] < 0.5 and np.isfinite(result["score"])
    code = main(["evaluate", "no-model", demos, "--methods", "goal_td3", "--episodes", "1"])
    lines = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(lines) == 1 and "pass --goal-model" in lines[0]
    jobs = make_jobs(
        None, demos_dir, "point_mass_maze", ["square"], ["goal_td3", "bc"], 1, 1, 1,
        budget="smoke", goal_model=out,
    )  # fmt: skip
    assert [j.goal_model for j in jobs] == [str(out), None]
    row = run_job(jobs[0])
    assert row["family"] == "bfm" and row["goal_model"] == str(out) and row["lookahead"] == 10
    assert row["data_digest"] == load_dataset(fixture_data).digest()  # the goal model's data


def test_the_radius_horizon_is_the_median_distance_h_steps_apart_in_one_episode(
    fixture_data: Path,
) -> None:
    """median_step(h) pairs s_t with s_{t+h} of the same episode only, never across an end."""
    import numpy as np

    data = load_dataset(fixture_data)
    obs, ends = data.observation, data.state_episode_end
    starts = data.next_index - 1
    pairs = [(t, t + 3) for t in starts if t + 3 <= ends[t]]
    want = float(np.median([np.linalg.norm(obs[b] - obs[a]) for a, b in pairs]))
    assert median_step(data, None, 3) == pytest.approx(want, rel=1e-6)
    assert median_step(data, None, 3) > median_step(data, None, 1)
    with pytest.raises(FbilError, match="lasts"):
        median_step(data, None, 10**7)
    with pytest.raises(FbilError, match="epsilon_horizon"):
        dataclasses.replace(goal_preset("point_mass_maze", "smoke"), epsilon_horizon=0)


def test_the_actor_schedule_of_meta_goal_agent_can_be_set(
    fixture_data: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """`--set policy_delay=1 --set actor_q=min_noisy` (and the target's clamp) reach the
    TD3 learner (an actor step at every update) and the saved config; a wrong name is one
    line."""
    data = load_dataset(fixture_data)

    def actor_moves_at_first_update(cfg: Any) -> bool:
        trainer = GoalTD3Trainer(cfg, data)
        before = [p.clone() for p in trainer.agent.actor.parameters()]
        trainer.update()
        after = trainer.agent.actor.parameters()
        return any(not torch.equal(a, b) for a, b in zip(before, after, strict=True))

    meta = dataclasses.replace(
        SMALL, policy_delay=1, actor_q="min_noisy", target_max=50.0, bc_alpha=2.5
    )
    agent_cfg = GoalTD3Trainer(meta, data).agent.cfg
    assert agent_cfg.actor_q == "min_noisy" and agent_cfg.target_max == 50.0
    assert agent_cfg.bc_alpha == 2.5 and GoalTD3Trainer(SMALL, data).agent.cfg.bc_alpha is None
    assert actor_moves_at_first_update(meta) and not actor_moves_at_first_update(SMALL)
    args = ["pretrain-goal", "point_mass_maze", "--data", str(fixture_data), "--preset", "smoke"]
    out = tmp_path / "goal"
    assert main([*args, "--out", str(out), "--set", "actor_q=min_noisy", "--set", "steps=5"]) == 0
    assert json.loads((out / CONFIG).read_text())["train_config"]["actor_q"] == "min_noisy"
    capsys.readouterr()
    assert main([*args, "--out", str(tmp_path / "bad"), "--set", "actor_q=mean"]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and "unknown actor_q 'mean'" in lines[0]


def test_the_fixed_goal_check_scores_a_goal_model_and_refuses_a_missing_demo(
    fixture_data: Path,
    demos_dir: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    from tests.script_module import load_script

    out = tmp_path / "goal"
    args = ["pretrain-goal", "point_mass_maze", "--data", str(fixture_data), "--preset", "smoke"]
    assert main([*args, "--out", str(out), "--set", "steps=20"]) == 0
    check = load_script("goal_reach_check").main
    capsys.readouterr()
    base = [str(out), "--demos", str(demos_dir), "--episodes", "1", "--draw", "0"]
    assert check([*base, "--tasks", "square", "--json"]) == 0
    row = json.loads(capsys.readouterr().out)["tasks"]["square"]
    assert 0.0 <= row["reached_share"] <= 1.0 and np.isfinite(row["q_start_mean"])
    assert row["epsilon"] == GoalModel.load(out).config.epsilon
    assert check([*base, "--tasks", "loop"]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("goal_reach_check: error:")
