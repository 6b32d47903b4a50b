"""The maze's geometry: walls, rooms and free floor, shared by its model, tasks and hooks."""

from __future__ import annotations

import numpy as np

ARENA_HALF = 0.3  # inner faces of the outer walls
ARM_HALF_LENGTH = 0.18  # arms of the "+" wall
WALL_HALF_THICKNESS = 0.02
JOINT_LIMIT = 0.29  # slide range of x and y
START_LOW, START_HIGH = 0.15, 0.29  # |x|, |y| of the top-left start box
MASS_RADIUS = 0.01
GOAL_SIZE = 0.015
ROOMS = ("top_left", "top_right", "bottom_left", "bottom_right")


def room_of(xy: np.ndarray) -> np.ndarray:
    """Index into ROOMS of each (x, y) row."""
    xy = np.asarray(xy)
    right = xy[..., 0] > 0
    bottom = xy[..., 1] < 0
    return right.astype(int) + 2 * bottom.astype(int)


def in_inner_wall(xy: np.ndarray, thick_margin: float, length_margin: float) -> np.ndarray:
    """True for each (..., 2) position within the "+" wall grown by the margins (across
    and along its arms)."""
    ax, ay = np.abs(xy[..., 0]), np.abs(xy[..., 1])
    thick, arm = WALL_HALF_THICKNESS + thick_margin, ARM_HALF_LENGTH + length_margin
    return ((ax < thick) & (ay < arm)) | ((ay < thick) & (ax < arm))


def near_wall(xy: np.ndarray, margin: float) -> np.ndarray:
    """True for each (..., 2) position of the mass whose rim lies within `margin` of a wall
    (the outer walls or the "+")."""
    outer = (np.abs(xy) > JOINT_LIMIT - MASS_RADIUS - margin).any(-1)
    r = MASS_RADIUS + margin
    return np.asarray(outer | in_inner_wall(xy, r, r))


def random_free_positions(rng: np.random.Generator, n: int) -> np.ndarray:
    """(n, 2) positions uniform over the free floor of all four rooms (walls excluded)."""
    margin = MASS_RADIUS + 0.005
    found: list[np.ndarray] = []
    while sum(len(f) for f in found) < n:
        xy = rng.uniform(-JOINT_LIMIT, JOINT_LIMIT, (2 * n, 2))
        found.append(xy[~in_inner_wall(xy, margin, WALL_HALF_THICKNESS + margin)])
    return np.concatenate(found)[:n]
