"""Oversampling the maze's doorway crossings: exact windows, counts, and refusals."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from fbil.data import load_dataset
from fbil.data.oversample import copy_sources, oversample_crossings
from fbil.data.storage import write_episode, write_manifest
from fbil.envs.maze_hooks import doorway_crossings
from fbil.errors import FbilError


def _episode(x: np.ndarray, y: float = 0.2, obs_dim: int = 4) -> dict[str, np.ndarray]:
    """A maze episode (row 0 the reset row) whose mass moves along x at height y."""
    n = len(x)
    obs = np.zeros((n, obs_dim), np.float32)
    obs[:, 0], obs[:, 1] = x, y
    action = np.full((n, 2), 0.5, np.float32)
    action[0] = 0
    return {
        "observation": obs,
        "action": action,
        "reward": np.zeros((n, 1), np.float32),
        "discount": np.ones((n, 1), np.float32),
        "physics": obs.astype(np.float64),
    }


def _dataset(root: Path, episodes: list[dict[str, np.ndarray]], domain: str) -> Path:
    for i, ep in enumerate(episodes):
        write_episode(root, i, ep)
    write_manifest(root, {"domain": domain})
    return root


def test_windows_around_each_crossing_are_added_copies_times(tmp_path: Path) -> None:
    crossing = _episode(np.linspace(-0.2, 0.2, 21))  # x > 0 from row 11 on: one crossing
    still = _episode(np.full(15, -0.2))
    src = _dataset(tmp_path / "src", [crossing, still], "point_mass_maze")
    made = oversample_crossings(src, tmp_path / "out", window=3, copies=2)
    data = load_dataset(tmp_path / "out")
    assert made["crossing_windows"] == 1 and made["episodes"] == 4
    assert data.num_transitions == 20 + 14 + 2 * 7  # rows 7..14 around row 11: 7 transitions
    window = data.observation[data.episode_start[2] : data.episode_end[2] + 1]
    np.testing.assert_array_equal(window, crossing["observation"][7:15])
    np.testing.assert_array_equal(window, data.observation[data.episode_start[3] :])
    assert data.action[data.episode_start[2]].tolist() == [0.0, 0.0]  # the reset row
    src_crossings = doorway_crossings(load_dataset(src))["transitions"]
    assert src_crossings == 1 and doorway_crossings(data)["transitions"] == 3
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["buffer", "manifest.json"]
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []


def test_oversampling_refuses_bad_input_and_writes_nothing(tmp_path: Path) -> None:
    still = _dataset(tmp_path / "still", [_episode(np.full(15, -0.2))], "point_mass_maze")
    crossing = _dataset(
        tmp_path / "cross", [_episode(np.linspace(-0.2, 0.2, 21))], "point_mass_maze"
    )
    cheetah = _dataset(
        tmp_path / "cheetah",
        [
            {
                k: np.zeros((6, w), np.float32)
                for k, w in (
                    ("observation", 17),
                    ("action", 6),
                    ("reward", 1),
                    ("discount", 1),
                    ("physics", 18),
                )
            }
        ],
        "cheetah",
    )
    for src, kwargs, expected in [
        (still, {}, "no transition that changes room"),
        (cheetah, {}, "only in point_mass_maze"),
        (crossing, {"copies": 0}, "must be >= 1"),
    ]:
        with pytest.raises(FbilError, match=expected):
            oversample_crossings(src, tmp_path / "out", **kwargs)
        assert not (tmp_path / "out").exists()
        assert not any(p.name.startswith(".") for p in tmp_path.iterdir())
    (tmp_path / "out").mkdir()
    with pytest.raises(FbilError, match="already exists"):
        oversample_crossings(crossing, tmp_path / "out")


def test_oversampling_from_the_command_line(tmp_path: Path) -> None:
    src = _dataset(tmp_path / "src", [_episode(np.linspace(-0.2, 0.2, 21))], "point_mass_maze")
    out = tmp_path / "out"
    args = ["dataset-oversample", str(src), "--out", str(out), "--window", "2", "--json"]
    res = subprocess.run([sys.executable, "-m", "fbil", *args], capture_output=True, text=True)
    assert res.returncode == 0, res.stderr
    made = json.loads(res.stdout)
    assert made["command"].startswith("fbil dataset-oversample") and made["copies"] == 4
    assert load_dataset(out).num_episodes == 1 + 4


def test_copy_sources_finds_each_window_in_the_episode_it_copies(tmp_path: Path) -> None:
    """Oversampled windows start mid-episode: `copy_sources` names the row where each one's
    observations occur in the longer episode (the windows' starts are not resets); whole
    episodes, and every episode of a dataset without windows, get -1."""
    crossing = _episode(np.linspace(-0.2, 0.2, 21))
    still = _episode(np.full(15, -0.1))
    src = _dataset(tmp_path / "src", [crossing, still], "point_mass_maze")
    oversample_crossings(src, tmp_path / "out", window=3, copies=2)
    data = load_dataset(tmp_path / "out")
    row7 = data.episode_start[0] + 7  # the window is rows 7..14 of the crossing episode
    assert copy_sources(data).tolist() == [-1, -1, row7, row7]
    assert copy_sources(load_dataset(src)).tolist() == [-1, -1]
    # A short episode that only resembles a stretch of a longer one is not a copy.
    near = crossing["observation"][7:15].copy()
    near[-1, 2] += 1e-3
    ep = {k: v[: len(near)].copy() for k, v in crossing.items()}
    ep["observation"] = near
    other = _dataset(tmp_path / "near", [crossing, ep], "point_mass_maze")
    assert copy_sources(load_dataset(other)).tolist() == [-1, -1]
