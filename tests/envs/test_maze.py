"""Maze geometry and the shape of its rewards (SPEC §2)."""

import numpy as np
import pytest

from fbil.envs import get_task, make_env, task_reward
from fbil.envs.maze import ROOMS, near_wall, room_of


def _push(start: tuple[float, float], action: tuple[float, float], steps: int = 300) -> np.ndarray:
    env = make_env("point_mass_maze", "loop")
    env.reset(seed=0)
    env.set_physics_state(np.array([*start, 0.0, 0.0]))
    xy = [np.array(start)]
    for _ in range(steps):
        obs = env.step(np.asarray(action, np.float32))[0]
        xy.append(obs[:2])
    return np.array(xy)


def _q(pos: np.ndarray, vel: np.ndarray, ctrl: np.ndarray | None = None) -> dict:
    pos, vel = np.atleast_2d(pos).astype(float), np.atleast_2d(vel).astype(float)
    ctrl = np.zeros_like(pos) if ctrl is None else np.atleast_2d(ctrl).astype(float)
    return {"position": pos, "velocity": vel, "control": ctrl}


def test_start_distribution_lies_in_the_top_left_room() -> None:
    env = make_env("point_mass_maze", "reach_top_right")
    starts = np.array([env.reset(seed=s)[0] for s in range(200)])
    assert np.all((starts[:, 0] >= -0.29) & (starts[:, 0] <= -0.15))
    assert np.all((starts[:, 1] >= 0.15) & (starts[:, 1] <= 0.29))
    np.testing.assert_array_equal(starts[:, 2:], 0.0)
    assert len(np.unique(starts[:, 0])) == 200  # seeds give distinct starts


@pytest.mark.parametrize("sx, sy", [(-1, 1), (1, 1), (-1, -1), (1, -1)])
def test_the_mass_cannot_cross_the_inner_walls(sx: int, sy: int) -> None:
    """From each room, push straight into both arms of the '+' wall: it holds."""
    start = (0.1 * sx, 0.1 * sy)
    # Toward the vertical arm, then toward the horizontal arm.
    across_x = _push(start, (-sx, 0.0))
    across_y = _push(start, (0.0, -sy))
    limit = 0.02 + 0.01 - 2e-3  # wall half-thickness + mass radius - soft-contact give
    assert np.all(sx * across_x[:, 0] >= limit)
    assert np.all(sy * across_y[:, 1] >= limit)
    assert np.all(room_of(across_x) == room_of(np.array(start)))


def test_the_doorways_let_the_mass_through_and_outer_walls_hold() -> None:
    through = _push((-0.1, 0.24), (1.0, 0.0))
    assert ROOMS[room_of(through[-1])] == "top_right"
    outer = _push((-0.25, 0.25), (-1.0, 1.0))
    assert np.all(np.abs(outer) <= 0.3)


@pytest.mark.parametrize(
    "task", ["reach_top_left", "reach_top_right", "reach_bottom_left", "reach_bottom_right"]
)
def test_goal_reward_peaks_at_the_goal(task: str) -> None:
    goal = np.array(get_task("point_mass_maze", task).goal)
    rng = np.random.default_rng(0)
    elsewhere = rng.uniform(-0.29, 0.29, (2000, 2))
    at_goal = task_reward("point_mass_maze", task, _q(goal, [0, 0]))
    assert at_goal[0] == pytest.approx(1.0)
    assert np.all(task_reward("point_mass_maze", task, _q(elsewhere, 0 * elsewhere)) <= 1.0)
    # Gaussian tolerance: 0.1 at the margin (0.015 + 0.09 from the goal), falling with distance.
    ray = goal + np.outer([0.0, 0.03, 0.06, 0.105, 0.2], [1.0, 0.0])
    r = task_reward("point_mass_maze", task, _q(ray, 0 * ray))
    assert r[0] == 1.0 and np.all(np.diff(r) < 0) and r[3] == pytest.approx(0.1)
    # Control cost: full control costs a fifth of the reward.
    full = task_reward("point_mass_maze", task, _q(goal, [0, 0], [1.0, -1.0]))
    assert full[0] == pytest.approx(0.8)


def test_loop_pays_clockwise_motion_on_the_diamond() -> None:
    # On the top-left edge of the diamond, moving up-right (clockwise) vs down-left.
    on_edge = [-0.12, 0.12]
    cw = task_reward("point_mass_maze", "loop", _q(on_edge, [0.08, 0.08]))[0]
    ccw = task_reward("point_mass_maze", "loop", _q(on_edge, [-0.08, -0.08]))[0]
    off = task_reward("point_mass_maze", "loop", _q([-0.25, 0.25], [0.08, 0.08]))[0]
    assert cw == pytest.approx(1.0) and ccw == pytest.approx(1 / 3) and off < cw


def test_square_and_fast_slow_turn_opposite_ways() -> None:
    top_band = [0.0, 0.24]
    assert task_reward("point_mass_maze", "square", _q(top_band, [0.1, 0]))[0] == 1.0
    assert task_reward("point_mass_maze", "square", _q(top_band, [-0.1, 0]))[0] == 0.0
    # fast_slow: slowly leftward along the top, fast upward on the right.
    assert task_reward("point_mass_maze", "fast_slow", _q(top_band, [-0.045, 0]))[0] == 1.0
    assert task_reward("point_mass_maze", "fast_slow", _q([0.24, 0.0], [0, 0.095]))[0] == 1.0
    assert task_reward("point_mass_maze", "fast_slow", _q([0.24, 0.0], [0, 0.045]))[0] == 0.0
    # Corners, where two bands overlap, pay nothing.
    assert task_reward("point_mass_maze", "square", _q([0.25, 0.25], [0.1, -0.1]))[0] == 0.0


def test_reach_long_rewards_clockwise_and_punishes_the_short_way() -> None:
    top = [0.0, 0.2]
    cw = task_reward("point_mass_maze", "reach_bottom_left_long", _q(top, [0.1, 0]))[0]
    ccw = task_reward("point_mass_maze", "reach_bottom_left_long", _q(top, [-0.1, 0]))[0]
    assert cw == pytest.approx(0.5) and ccw == pytest.approx(-10.0)
    goal = task_reward("point_mass_maze", "reach_bottom_left_long", _q([-0.15, -0.15], [0, 0]))
    assert goal[0] == pytest.approx(1.0)


def test_near_wall_marks_the_outer_walls_and_the_plus_only() -> None:
    xy = np.array(
        [
            [0.285, 0.15],  # against the right wall (joint limit 0.29)
            [-0.15, -0.285],  # against the bottom wall
            [0.031, 0.10],  # touching the "+" arm's side (half thickness 0.02 + radius 0.01)
            [0.10, 0.031],  # touching the other arm
            [-0.15, 0.15],  # open floor, a room's centre
            [0.24, 0.0],  # a doorway, 0.06 past the arm's end
        ]
    )
    assert near_wall(xy, 0.01).tolist() == [True, True, True, True, False, False]
    assert not near_wall(xy[2:4], 0.0).any()  # 1 mm from the arm: outside a zero margin
