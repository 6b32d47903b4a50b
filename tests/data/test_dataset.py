"""Relabeling a loaded dataset: vectorised, cached, equal to the rewards seen online."""

from pathlib import Path

import numpy as np

from fbil.data import load_dataset
from fbil.data.storage import episode_arrays, write_episode
from fbil.envs import BatchedEnv, RandomPolicy


def test_dataset_rewards_equal_online_rewards_and_are_cached(tmp_path: Path) -> None:
    starts = np.array([[-0.15, 0.15, 0.05, 0.0], [0.12, 0.2, -0.05, 0.0]])
    ep = BatchedEnv("point_mass_maze", "reach_top_left", 2).rollout(
        RandomPolicy(2, seed=0), [0, 1], steps=150, start_states=starts
    )
    for i in range(2):
        write_episode(
            tmp_path,
            i,
            episode_arrays(ep.observation[i], ep.action[i], ep.reward[i], ep.physics[i]),
        )
    data = load_dataset(tmp_path)
    online = ep.reward.reshape(-1)
    np.testing.assert_allclose(data.reward("reach_top_left"), online, atol=1e-6)
    assert np.ptp(online) > 0.1
    caches = list((tmp_path / "cache").glob("quantities_*.npz"))
    assert len(caches) == 1
    # A fresh load reads the cached quantities (no physics pass) and agrees.
    again = load_dataset(tmp_path)
    again.physics = None  # type: ignore[method-assign]  # would fail if called
    np.testing.assert_array_equal(again.reward("loop"), data.reward("loop"))


def test_doorway_crossings_count_room_changes_in_the_raw_files(tmp_path: Path) -> None:
    """Real maze rollouts pushed through two doorways, counted again from the episode
    files: a crossing is a step whose quadrant (signs of x and y) changes."""
    from fbil.envs.maze_hooks import doorway_crossings

    # Next to the left doorway pushing down, next to the top doorway pushing right.
    starts = np.array([[-0.24, 0.03, 0.0, 0.0], [-0.03, 0.24, 0.0, 0.0]])
    push = np.array([[0.0, -1.0], [1.0, 0.0]], np.float32)
    ep = BatchedEnv("point_mass_maze", "loop", 2).rollout(
        lambda obs, step: push, [0, 1], steps=60, start_states=starts
    )
    for i in range(2):
        arrays = episode_arrays(ep.observation[i], ep.action[i], ep.reward[i], ep.physics[i])
        write_episode(tmp_path, i, arrays)
    expected = 0
    for f in sorted((tmp_path / "buffer").glob("*.npz")):
        xy = np.load(f)["observation"][:, :2]
        quadrant = (xy[:, 0] > 0).astype(int) + 2 * (xy[:, 1] < 0).astype(int)
        expected += int((quadrant[1:] != quadrant[:-1]).sum())
    got = doorway_crossings(load_dataset(tmp_path))
    assert expected == 2 and got["transitions"] == expected
    assert got["pairs"] == {"top_left->bottom_left": 1, "top_left->top_right": 1}
    assert got["per_episode"] == 1.0


def test_the_digest_names_the_content_not_the_copy(fixture_data: Path, tmp_path: Path) -> None:
    """Two copies of one dataset share a digest; a copy with one action changed (what a
    regeneration on another kind of CPU gives, in miniature) does not."""
    import shutil

    copy = tmp_path / "copy"
    shutil.copytree(fixture_data, copy)
    assert load_dataset(copy).digest() == load_dataset(fixture_data).digest()
    first = sorted((copy / "buffer").glob("*.npz"))[0]
    arrays = dict(np.load(first))
    arrays["action"][3, 0] += 1e-3
    np.savez(first, **arrays)
    shutil.rmtree(copy / "cache", ignore_errors=True)
    assert load_dataset(copy).digest() != load_dataset(fixture_data).digest()
