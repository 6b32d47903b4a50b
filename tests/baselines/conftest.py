"""Fixtures of the baseline tests."""

from pathlib import Path

import numpy as np
import pytest

from fbil.data import list_episodes, load_episode
from fbil.envs.relabel import relabel
from fbil.imitation import Demos, Trajectory


@pytest.fixture(scope="session")
def demos_dir(fixture_data: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """square.npz: two fixture episodes relabeled with the task's reward (as the
    evaluation tests make them), and an action-free copy."""
    out = tmp_path_factory.mktemp("demos")
    trajs = []
    for f in list_episodes(fixture_data)[:2]:
        ep = load_episode(f.path)
        reward = relabel("point_mass_maze", "square", ep["physics"][1:], ep["action"][1:])
        trajs.append(Trajectory(ep["observation"], ep["action"][1:], reward.astype(np.float32)))
    meta = {"domain": "point_mass_maze", "task": "square"}
    meta["return_mean"] = float(np.mean([float(t.reward.sum()) for t in trajs]))  # type: ignore[union-attr]
    Demos(trajs, meta).save(out / "square.npz")
    free = [Trajectory(t.observation, None, t.reward) for t in trajs]
    Demos(free, meta).save(out / "square_free.npz")
    return out
