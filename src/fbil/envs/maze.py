"""point_mass_maze: a point mass in a four-room maze (custom MJCF, 8 tasks).

Geometry and rewards follow the maze of the URLB/ExORL line of work as restated in
SPEC §2: a 0.6 x 0.6 arena, a "+"-shaped inner wall whose arms stop 0.12 short of the
outer walls (the four doorways), and episodes starting in the top-left room.
"""

from __future__ import annotations

import collections
from typing import Any

import numpy as np
from dm_control.mujoco import Physics
from dm_control.suite import base, common
from dm_control.utils import rewards

from fbil.envs import maze_hooks
from fbil.envs.base import DomainSpec, Quantities, TaskSpec, linear_tolerance

# The geometry, re-exported: `maze.ROOMS`, `maze.in_inner_wall`, ... read as before.
from fbil.envs.maze_geometry import ARENA_HALF as ARENA_HALF
from fbil.envs.maze_geometry import ARM_HALF_LENGTH as ARM_HALF_LENGTH
from fbil.envs.maze_geometry import GOAL_SIZE as GOAL_SIZE
from fbil.envs.maze_geometry import JOINT_LIMIT as JOINT_LIMIT
from fbil.envs.maze_geometry import MASS_RADIUS as MASS_RADIUS
from fbil.envs.maze_geometry import ROOMS as ROOMS
from fbil.envs.maze_geometry import START_HIGH as START_HIGH
from fbil.envs.maze_geometry import START_LOW as START_LOW
from fbil.envs.maze_geometry import WALL_HALF_THICKNESS as WALL_HALF_THICKNESS
from fbil.envs.maze_geometry import in_inner_wall as in_inner_wall
from fbil.envs.maze_geometry import near_wall as near_wall
from fbil.envs.maze_geometry import random_free_positions as random_free_positions
from fbil.envs.maze_geometry import room_of as room_of

_XML = """
<mujoco model="fbil point-mass maze">
  <include file="./common/skybox.xml"/>
  <include file="./common/visual.xml"/>
  <include file="./common/materials.xml"/>
  <option timestep="0.02"/>
  <default>
    <joint type="slide" limited="true" range="-{lim} {lim}" damping="1"/>
    <motor gear=".1" ctrlrange="-1 1" ctrllimited="true"/>
    <default class="wall">
      <geom type="box" material="site"/>
    </default>
  </default>
  <worldbody>
    <light name="light" pos="0 0 1"/>
    <camera name="top" pos="0 0 .75"/>
    <geom name="ground" type="plane" size="{a} {a} .1" material="grid"/>
    <geom name="wall_left" class="wall" pos="-{ao} 0 .02" size="{t} {al} .02"/>
    <geom name="wall_right" class="wall" pos="{ao} 0 .02" size="{t} {al} .02"/>
    <geom name="wall_bottom" class="wall" pos="0 -{ao} .02" size="{al} {t} .02"/>
    <geom name="wall_top" class="wall" pos="0 {ao} .02" size="{al} {t} .02"/>
    <geom name="inner_horizontal" class="wall" pos="0 0 .02" size="{arm} {t} .02"/>
    <geom name="inner_vertical" class="wall" pos="0 0 .02" size="{t} {arm} .02"/>
    <body name="pointmass" pos="0 0 {r}">
      <joint name="root_x" axis="1 0 0"/>
      <joint name="root_y" axis="0 1 0"/>
      <geom name="pointmass" type="sphere" size="{r}" material="self" mass=".3"/>
    </body>
    <geom name="target" type="sphere" pos="{gx} {gy} {r}" size="{g}" material="target"
          contype="0" conaffinity="0"/>
  </worldbody>
  <actuator>
    <motor name="push_x" joint="root_x"/>
    <motor name="push_y" joint="root_y"/>
  </actuator>
</mujoco>
"""


def maze_xml(goal: tuple[float, float] | None = None) -> str:
    """The maze's MJCF; `goal` only places the (non-colliding) target marker."""
    gx, gy = goal if goal is not None else (-1.0, -1.0)
    t = WALL_HALF_THICKNESS
    return _XML.format(
        lim=JOINT_LIMIT,
        a=ARENA_HALF,
        ao=ARENA_HALF + t,
        al=ARENA_HALF + 2 * t,
        t=t,
        arm=ARM_HALF_LENGTH,
        r=MASS_RADIUS,
        g=GOAL_SIZE,
        gx=gx,
        gy=gy,
    )


class _MazeInit(base.Task):
    """Draws the start state from the task's own RNG and builds observations."""

    def initialize_episode(self, physics: Any) -> None:
        physics.data.qpos[0] = self.random.uniform(-START_HIGH, -START_LOW)
        physics.data.qpos[1] = self.random.uniform(START_LOW, START_HIGH)
        physics.data.qvel[:] = 0.0
        super().initialize_episode(physics)

    def get_observation(self, physics: Any) -> collections.OrderedDict[str, np.ndarray]:
        obs: collections.OrderedDict[str, np.ndarray] = collections.OrderedDict()
        obs["position"] = physics.position()
        obs["velocity"] = physics.velocity()
        return obs

    def get_reward(self, physics: Any) -> float:
        return 0.0  # rewards come from the TaskSpec, see fbil.envs.env


def _build(rng: np.random.RandomState) -> tuple[Any, Any]:
    physics = Physics.from_xml_string(maze_xml(), common.ASSETS)
    return physics, _MazeInit(random=rng)


def _read(physics: Any) -> dict[str, np.ndarray | float]:
    return {
        "position": physics.data.qpos[:2].copy(),
        "velocity": physics.data.qvel[:2].copy(),
        "control": physics.data.ctrl[:2].copy(),
    }


def _reach_reward(q: Quantities, goal: tuple[float, float]) -> np.ndarray:
    dist = np.linalg.norm(q["position"] - np.asarray(goal), axis=-1)
    near = rewards.tolerance(dist, bounds=(0, GOAL_SIZE), margin=6 * GOAL_SIZE)
    control = rewards.tolerance(q["control"], margin=1, value_at_margin=0, sigmoid="quadratic")
    small_control = (4 + np.mean(control, axis=-1)) / 5
    return np.asarray(near * small_control, dtype=np.float64)


def _reach(goal: tuple[float, float]) -> Any:
    def reward(q: Quantities) -> np.ndarray:
        return _reach_reward(q, goal)

    return reward


def _one_band(*bands: np.ndarray) -> np.ndarray:
    """True where the mass lies in exactly one band (corners, where bands overlap, pay 0)."""
    return np.sum(bands, axis=0) <= 1


def _reach_long(q: Quantities) -> np.ndarray:
    """Reach bottom-left, but away from the goal pay clockwise circulation (the long way)."""
    reach = _reach_reward(q, (-0.15, -0.15))
    x, y = q["position"][:, 0], q["position"][:, 1]
    vx, vy = q["velocity"][:, 0], q["velocity"][:, 1]
    up, right, left, down = y > 0.15, x > 0.15, x < -0.15, y < -0.15
    cvx, cvy = np.clip(vx, -0.1, 0.1), np.clip(vy, -0.1, 0.1)
    # Right-way motion is weighted 5, wrong-way motion 100.
    circ = (
        cvx * up * np.where(vx >= 0, 5, 100)
        - cvy * right * np.where(vy <= 0, 5, 100)
        + cvy * left * np.where(vy >= 0, 5, 100)
        - cvx * down * np.where(vx <= 0, 5, 100)
    )
    circ = np.where(_one_band(up, right, left, down), circ, 0.0)
    return np.where(reach < 0.01, circ, reach)


def _loop(q: Quantities) -> np.ndarray:
    """Clockwise along the diamond through the four doorways."""
    x, y = q["position"][:, 0], q["position"][:, 1]
    vx, vy = q["velocity"][:, 0], q["velocity"][:, 1]
    left, top = x <= 0, y >= 0
    # Clockwise: +x on the top half, -x on the bottom; +y on the left half, -y on the right.
    vx_rew = np.where(
        top, linear_tolerance(vx, 0.06, 0.1, 0.01), linear_tolerance(vx, -0.1, -0.06, 0.01)
    )
    vy_rew = np.where(
        left, linear_tolerance(vy, 0.06, 0.1, 0.01), linear_tolerance(vy, -0.1, -0.06, 0.01)
    )
    # Edge of the diamond in this quadrant: |a x + b y + c| / sqrt(2) with b = -1.
    a = np.where(left == top, 1.0, -1.0)
    c = np.where(top, 0.24, -0.24)
    dist = np.abs(a * x - y + c) / np.sqrt(2)
    dist_rew = linear_tolerance(dist, 0.0, 0.02, 0.02)
    return np.asarray((dist_rew + vx_rew + vy_rew) / 3)


def _square(q: Quantities) -> np.ndarray:
    """Clockwise along the perimeter bands |coord| > 0.2."""
    x, y = q["position"][:, 0], q["position"][:, 1]
    vx, vy = q["velocity"][:, 0], q["velocity"][:, 1]
    up, right, left, down = y > 0.2, x > 0.2, x < -0.2, y < -0.2
    r = (
        np.abs(np.clip(vx, 0, 0.1) * 10 * up)
        + np.abs(np.clip(vy, -0.1, 0) * 10 * right)
        + np.abs(np.clip(vy, 0, 0.1) * 10 * left)
        + np.abs(np.clip(vx, -0.1, 0) * 10 * down)
    )
    return np.where(_one_band(up, right, left, down), r, 0.0)


def _fast_slow(q: Quantities) -> np.ndarray:
    """Counter-clockwise in the bands 0.2 < |coord| < 0.28: slow across, fast up and down."""
    x, y = q["position"][:, 0], q["position"][:, 1]
    vx, vy = q["velocity"][:, 0], q["velocity"][:, 1]
    up, down = (y > 0.2) & (y < 0.28), (y < -0.2) & (y > -0.28)
    right, left = (x > 0.2) & (x < 0.28), (x < -0.2) & (x > -0.28)
    r = (
        linear_tolerance(vx, -0.05, -0.04, 0.01) * up
        + linear_tolerance(vy, 0.09, 0.1, 0.01) * right
        + linear_tolerance(vy, -0.1, -0.09, 0.01) * left
        + linear_tolerance(vx, 0.04, 0.05, 0.01) * down
    )
    return np.where(_one_band(up, right, left, down), r, 0.0)


_CUSTOM = "URLB/ExORL maze (facebookresearch/offline_rl)"
_GOALS = {
    "reach_top_left": (-0.15, 0.15),
    "reach_top_right": (0.15, 0.15),
    "reach_bottom_left": (-0.15, -0.15),
    "reach_bottom_right": (0.15, -0.15),
}
_TASKS = [
    TaskSpec(
        name,
        _reach(goal),
        f"reach the centre of the {name[6:].replace('_', '-')} room",
        _CUSTOM,
        goal=goal,
    )
    for name, goal in _GOALS.items()
]
_TASKS += [
    TaskSpec(
        "reach_bottom_left_long",
        _reach_long,
        "reach the bottom-left room the long way round (clockwise)",
        _CUSTOM,
        goal=(-0.15, -0.15),
        path=((-0.22, 0.24), (0.24, 0.24), (0.24, -0.24), (-0.15, -0.24), (-0.15, -0.15)),
    ),
    TaskSpec(
        "loop",
        _loop,
        "loop clockwise along the diamond through the four doorways",
        _CUSTOM,
        path=((-0.24, 0.0), (0.0, 0.24), (0.24, 0.0), (0.0, -0.24), (-0.24, 0.0)),
    ),
    TaskSpec(
        "square",
        _square,
        "loop clockwise along the outer walls",
        _CUSTOM,
        path=((-0.25, 0.25), (0.25, 0.25), (0.25, -0.25), (-0.25, -0.25), (-0.25, 0.25)),
    ),
    TaskSpec(
        "fast_slow",
        _fast_slow,
        "loop counter-clockwise near the walls, slow across and fast up and down",
        _CUSTOM,
        path=((0.24, 0.24), (-0.24, 0.24), (-0.24, -0.24), (0.24, -0.24), (0.24, 0.24)),
    ),
]

DOMAIN = DomainSpec(
    name="point_mass_maze",
    obs_dim=4,
    act_dim=2,
    physics_dim=4,
    control_timestep=0.02,
    quantity_shapes={"position": (2,), "velocity": (2,), "control": (2,)},
    tasks={t.name: t for t in _TASKS},
    build=_build,
    read_quantities=_read,
    hooks=maze_hooks.HOOKS,
)
