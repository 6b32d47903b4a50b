"""`scripts/maze_controller_demos.py`: the hand-written reach controller gets to its goal and
rests there, its files load as demos, and it refuses tasks it has no route for."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from fbil.envs import maze
from fbil.imitation.demos import Demos
from tests.script_module import load_script


def _module():  # type: ignore[no-untyped-def]
    return load_script("maze_controller_demos")


@pytest.mark.parametrize("task", ["reach_top_left", "reach_bottom_right"])
def test_controller_reaches_and_rests_at_the_goal(task: str) -> None:
    demos = _module().controller_demos(task, episodes=2, seed=3)
    goal = np.asarray(maze.DOMAIN.tasks[task].goal)
    for traj in demos.trajectories:
        end = traj.observation[-100:]
        assert np.linalg.norm(end[:, :2] - goal, axis=1).max() < maze.GOAL_SIZE
        assert np.abs(end[:, 2:]).max() < 1e-3  # at rest
        assert np.abs(traj.action[-100:]).max() == 0.0  # push off
        # The far goal takes the longest route: fewer rewarded steps, still most of them.
        assert traj.reward.sum() > (900 if task == "reach_top_left" else 550)


def test_files_load_as_demos_and_bad_input_is_refused(tmp_path: Path) -> None:
    mod = _module()
    assert mod.main(["--out", str(tmp_path), "--episodes", "1", "--tasks", "reach_top_left"]) == 0
    demos = Demos.load(tmp_path / "reach_top_left.npz")
    assert demos.has_actions and demos.metadata["task"] == "reach_top_left"
    assert len(demos.trajectories[0]) == 1000
    assert mod.main(["--out", str(tmp_path), "--tasks", "loop"]) == 2
    assert mod.main(["--out", str(tmp_path), "--episodes", "0"]) == 2


def test_the_long_task_pays_the_clockwise_route_and_punishes_the_short_one() -> None:
    """reach_bottom_left_long: the controller's clockwise route earns about what the TD3
    expert does (666); the short route down the left doorway moves the wrong way and loses
    (and no route can pass 1 000, the task's maximum return)."""
    from fbil.envs import max_return
    from fbil.envs.rollout import BatchedEnv

    mod = _module()
    long = mod.controller_demos("reach_bottom_left_long", episodes=2, seed=3)
    returns = [t.reward.sum() for t in long.trajectories]
    assert min(returns) > 650 and max(returns) < max_return(
        "point_mass_maze", "reach_bottom_left_long"
    )
    env = BatchedEnv("point_mass_maze", "reach_bottom_left_long", 2)
    short = env.rollout(mod.WaypointController(mod.ROUTES["reach_bottom_left"], 2), [5, 6])
    assert short.reward.sum(axis=-1).max() < 0
