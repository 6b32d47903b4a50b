"""TD3 experts: offline learning on the fixture, demonstrations, shifted starts, errors."""

import json
from pathlib import Path

import numpy as np
import pytest
import torch

from fbil.agents.expert import load_expert, make_demos, offline_sampler, train_expert
from fbil.agents.td3 import TD3, TD3Config
from fbil.data import load_dataset
from fbil.errors import FbilError
from fbil.imitation import Demos


def test_offline_td3_reduces_its_critic_loss_on_the_fixture(fixture_data: Path) -> None:
    data = load_dataset(fixture_data)
    reward = torch.from_numpy(data.reward("reach_top_left"))
    j = torch.from_numpy(data.next_index)
    obs, act = torch.from_numpy(data.observation), torch.from_numpy(data.action)
    agent = TD3(4, 2, TD3Config(hidden=64, batch_size=256, bc_alpha=2.5), seed=0)
    # A fixed evaluation batch: the critic's TD error on it must fall as it learns.
    k = torch.randperm(len(j), generator=torch.Generator().manual_seed(0))[:1024]
    rows = j[k]

    def td_error() -> float:
        with torch.no_grad():
            next_a = agent.actor_target(obs[rows])
            y = reward[k] + 0.99 * agent._q(agent.critic_targets, obs[rows], next_a).min(-1).values
            return float(
                ((agent._q(agent.critics, obs[rows - 1], act[rows])[:, 0] - y) ** 2).mean()
            )

    before = td_error()
    g = torch.Generator().manual_seed(1)
    for _ in range(300):
        b = torch.randint(0, len(j), (256,), generator=g)
        r = j[b]
        agent.update(obs[r - 1], act[r], reward[b], obs[r], torch.ones(256))
    assert td_error() < 0.5 * before


@pytest.fixture(scope="module")
def expert_dir(fixture_data: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("expert") / "loop"
    train_expert(
        "point_mass_maze",
        "loop",
        "offline",
        out,
        data=fixture_data,
        steps=200,
        eval_every=100,
        eval_episodes=2,
        progress=False,
    )
    return out


def test_demos_round_trip_with_returns(expert_dir: Path, tmp_path: Path) -> None:
    demos = make_demos(expert_dir, 3, tmp_path / "d.npz", seed=1)
    back = Demos.load(tmp_path / "d.npz")
    assert len(back) == 3 and back.has_actions
    for t in back.trajectories:
        assert t.observation.shape == (1001, 4) and t.action.shape == (1000, 2)
        assert t.physics is not None and t.reward is not None
    np.testing.assert_allclose(
        [t.reward.sum() for t in back.trajectories], demos.metadata["returns"], rtol=1e-5
    )
    assert back.metadata["task"] == "loop" and back.metadata["start"] == "standard"
    make_demos(expert_dir, 3, tmp_path / "f.npz", seed=1, physics="first")
    first = Demos.load(tmp_path / "f.npz")
    assert [t.physics is None for t in first.trajectories] == [False, True, True]
    np.testing.assert_array_equal(first.trajectories[0].physics, back.trajectories[0].physics)
    with pytest.raises(FbilError, match="unknown --physics 'some'; valid: all, first, none"):
        make_demos(expert_dir, 3, tmp_path / "x.npz", physics="some")


def test_shifted_maze_demos_start_in_the_top_right_room(expert_dir: Path, tmp_path: Path) -> None:
    shifted = make_demos(expert_dir, 4, tmp_path / "s.npz", start="shifted")
    standard = make_demos(expert_dir, 4, tmp_path / "t.npz", start="standard")
    for t in shifted.trajectories:
        assert 0.15 <= t.observation[0, 0] <= 0.29 and 0.15 <= t.observation[0, 1] <= 0.29
    for t in standard.trajectories:
        assert -0.29 <= t.observation[0, 0] <= -0.15 and 0.15 <= t.observation[0, 1] <= 0.29


def test_expert_errors_are_one_line(fixture_data: Path, tmp_path: Path) -> None:
    with pytest.raises(FbilError, match="valid tasks"):
        train_expert("point_mass_maze", "orbit", "offline", tmp_path / "a", data=fixture_data)
    with pytest.raises(FbilError, match="not walker"):
        train_expert("walker", "walk", "offline", tmp_path / "b", data=fixture_data, steps=1)
    with pytest.raises(FbilError, match="no expert in"):
        load_expert(tmp_path / "empty")
    with pytest.raises(FbilError, match="needs --data"):
        train_expert("point_mass_maze", "loop", "offline", tmp_path / "c")


def test_demos_come_from_the_best_evaluated_actor(expert_dir: Path) -> None:
    """The expert keeps the actor of its best evaluation, and demos are recorded with it."""
    rows = (expert_dir / "train_log.csv").read_text().splitlines()[1:]
    returns = [float(r.split(",")[1]) for r in rows]
    meta = json.loads((expert_dir / "expert.json").read_text())
    assert meta["best_return_mean"] == pytest.approx(max(returns), abs=0.01)
    _, loaded = load_expert(expert_dir)
    assert loaded["actor"] == "best.safetensors"


def test_nstep_samples_sum_discounted_rewards_within_one_episode(fixture_data: Path) -> None:
    data = load_dataset(fixture_data)
    cfg = TD3Config(nstep=5, batch_size=512, gamma=0.9)
    obs, act, ret, nxt, disc = offline_sampler(data, "reach_top_left", cfg, torch.Generator())()
    rewards = data.reward("reach_top_left")
    position = {tuple(o): i for i, o in enumerate(data.observation.tolist())}
    for b in range(64):
        start = position[tuple(obs[b].tolist())]  # state index of s
        end = data.state_episode_end[start]
        assert start + 5 <= end  # all five steps inside the episode
        np.testing.assert_allclose(nxt[b].numpy(), data.observation[start + 5])
        np.testing.assert_allclose(act[b].numpy(), data.action[start + 1])
        rows = np.searchsorted(data.next_index, np.arange(start + 1, start + 6))
        expected = sum(0.9**i * rewards[r] for i, r in enumerate(rows))
        assert float(ret[b]) == pytest.approx(float(expected), rel=1e-5, abs=1e-6)
    torch.testing.assert_close(disc, torch.full_like(disc, 0.9**4))


def test_online_nstep_samples_follow_one_env_within_one_episode() -> None:
    from fbil.agents.expert import _OnlineLoop

    cfg = TD3Config(hidden=32, batch_size=64, nstep=3)
    agent = TD3(4, 2, cfg, seed=0)
    # Huge start_steps: random actions, no updates; 2 envs interleave rows in the buffer.
    loop = _OnlineLoop(agent, "point_mass_maze", "loop", 2, 10**9, seed=0, step=0)
    for _ in range(40):
        loop.step()
    obs, act, reward, next_obs, discount = loop.sample(agent.cfg.batch_size)
    assert len(obs) > 0
    batch = (obs.numpy(), act.numpy(), reward.numpy(), next_obs.numpy())
    for s, a, r, s_n in zip(*batch, strict=True):
        n = loop.size
        (k,) = np.flatnonzero((loop.obs[:n] == s).all(-1) & (loop.act[:n] == a).all(-1))
        same_env = k + 2 * np.arange(3)  # the same env's next two rows
        assert (loop.t[same_env] == loop.t[k] + np.arange(3)).all()
        np.testing.assert_allclose(r, (loop.rew[same_env] * 0.99 ** np.arange(3)).sum(), 1e-5)
        np.testing.assert_array_equal(s_n, loop.next_obs[same_env[-1]])
    np.testing.assert_allclose(discount.numpy(), 0.99**2)


def test_online_resume_keeps_the_replay_buffer(tmp_path: Path) -> None:
    from fbil.checkpoint import load_state

    out = tmp_path / "online"
    kw = dict(config=TD3Config(hidden=32, batch_size=16), eval_episodes=1, progress=False)
    kw |= dict(start_steps=10, checkpoint_seconds=0.0)
    train_expert("point_mass_maze", "loop", "online", out, steps=30, eval_every=30, **kw)
    first = load_state(out / "checkpoint.safetensors")["learner"]
    assert len(first["rew"]) == 30
    kw |= dict(resume=True)
    train_expert("point_mass_maze", "loop", "online", out, steps=50, eval_every=50, **kw)
    second = load_state(out / "checkpoint.safetensors")
    assert second["step"] == 50 and len(second["learner"]["rew"]) == 50
    torch.testing.assert_close(second["learner"]["obs"][:30], first["obs"])
    # expert.json keeps both invocations, so a resumed expert still shows how it started.
    assert len(json.loads((out / "expert.json").read_text())["commands"]) == 2
    # The log's wall time goes on from the first run's instead of restarting at zero.
    rows = (out / "train_log.csv").read_text().splitlines()[1:]
    walls = [float(r.split(",")[-1]) for r in rows]
    assert [int(r.split(",")[0]) for r in rows] == [30, 50] and walls[1] >= walls[0]


def test_online_init_starts_from_the_offline_expert(expert_dir: Path, tmp_path: Path) -> None:
    """--init copies the expert's networks and input statistics; warm-up rows come from its
    (noisy) actor, not from uniform random actions."""
    from fbil.checkpoint import load_state

    source, _ = load_expert(expert_dir)
    out = tmp_path / "tuned"
    kw = dict(eval_episodes=1, progress=False, start_steps=20, checkpoint_seconds=0.0)
    cfg = TD3Config(exploration_noise=0.0)  # noise-free: warm-up actions are the actor's
    train_expert(
        "point_mass_maze", "loop", "online", out, steps=20, eval_every=20, config=cfg,
        init=expert_dir, **kw,
    )  # fmt: skip
    state = load_state(out / "checkpoint.safetensors")
    torch.testing.assert_close(state["agent"]["obs_stats"], source.obs_stats)
    # 20 steps, all warm-up: no update ran, so the actor is still the expert's.
    for k, v in source.actor.state_dict().items():
        torch.testing.assert_close(state["agent"]["actor"][k], v)
    rows = state["learner"]
    torch.testing.assert_close(rows["act"], torch.from_numpy(source.act(rows["obs"].numpy())))


def test_an_expert_without_its_checkpoint_still_loads(expert_dir: Path, tmp_path: Path) -> None:
    """expert.json + best.safetensors (committed without the replay buffer) is an expert:
    the same actor acts, and --init fine-tunes from it."""
    import shutil

    kept = tmp_path / "kept"
    kept.mkdir()
    for name in ("expert.json", "best.safetensors"):
        shutil.copy(expert_dir / name, kept / name)
    full, _ = load_expert(expert_dir)
    light, meta = load_expert(kept)
    assert meta["actor"] == "best.safetensors"
    obs = np.random.default_rng(0).normal(size=(5, 4)).astype(np.float32)
    np.testing.assert_array_equal(full.act(obs), light.act(obs))
    (kept / "best.safetensors").unlink()
    with pytest.raises(FbilError, match="no expert in"):
        load_expert(kept)


def test_online_init_errors_are_one_line(
    expert_dir: Path, fixture_data: Path, tmp_path: Path
) -> None:
    with pytest.raises(FbilError, match="use it with --mode online"):
        train_expert(
            "point_mass_maze", "loop", "offline", tmp_path / "a", data=fixture_data, steps=1,
            init=expert_dir,
        )  # fmt: skip
    with pytest.raises(FbilError, match="no expert in"):
        train_expert("point_mass_maze", "loop", "online", tmp_path / "b", init=tmp_path / "x")
    with pytest.raises(FbilError, match="not cheetah"):
        train_expert("cheetah", "run", "online", tmp_path / "c", init=expert_dir)
    with pytest.raises(FbilError, match="pass --set hidden=256"):
        small = TD3Config(hidden=32)
        train_expert(
            "point_mass_maze", "loop", "online", tmp_path / "d", config=small, init=expert_dir
        )


def test_online_with_a_dataset_mixes_its_rows_into_every_minibatch(
    fixture_data: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """RLPD's symmetric sampling: with --data online, offline_share of each minibatch comes
    from the dataset relabeled with the task, the rest from the replay buffer, and the
    dataset's statistics standardise the observations."""
    data = load_dataset(fixture_data)
    seen: list[tuple[torch.Tensor, ...]] = []
    update = TD3.update

    def spy(self: TD3, *batch: torch.Tensor) -> dict[str, float]:
        seen.append(batch)
        return update(self, *batch)

    monkeypatch.setattr(TD3, "update", spy)
    cfg = TD3Config(hidden=32, batch_size=40, offline_share=0.25)
    kw = dict(config=cfg, eval_episodes=1, progress=False, start_steps=10, data=fixture_data)
    out = tmp_path / "rlpd"
    train_expert("point_mass_maze", "loop", "online", out, steps=14, eval_every=14, **kw)
    assert len(seen) == 5  # steps 10-14: an update per environment step from the 10th on
    known = {tuple(row) for row in data.observation.tolist()}
    rewards = data.reward("loop")
    for obs, _, reward, _, _ in seen:
        assert len(obs) == len(reward) == 40
        from_data = [tuple(row) in known for row in obs.tolist()]
        assert from_data == [False] * 30 + [True] * 10  # the buffer's rows, then the data's
        assert set(reward[30:].tolist()) <= set(rewards.astype(np.float32).tolist())
    from fbil.checkpoint import load_state

    stats = load_state(out / "checkpoint.safetensors")["agent"]["obs_stats"]
    np.testing.assert_allclose(stats[0].numpy(), data.observation.mean(0), rtol=1e-5, atol=1e-6)
    assert json.loads((out / "expert.json").read_text())["data"] == str(fixture_data)
    with pytest.raises(FbilError, match="draws no dataset row"):
        small = TD3Config(hidden=32, batch_size=40, offline_share=0.01)
        train_expert(
            "point_mass_maze",
            "loop",
            "online",
            tmp_path / "none",
            steps=2,
            **{**kw, "config": small},
        )
