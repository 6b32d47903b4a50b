"""quadruped: dm_control's four-legged ant (walk, run) plus stand and jump."""

from __future__ import annotations

from typing import Any

import numpy as np
from dm_control.suite import common, quadruped

from fbil.envs.base import DomainSpec, Quantities, TaskSpec, linear_tolerance, quiet_model_compile
from fbil.envs.locomotion import Locomotion

WALK_SPEED, RUN_SPEED = 0.5, 5.0
JUMP_HEIGHT = 1.0
INF = float("inf")
FLOOR_SIZE = 10  # dm_control's walk floor; the floor is a plane, its size only shows


def _build(rng: np.random.RandomState) -> tuple[Any, Any]:
    with quiet_model_compile():
        physics = quadruped.Physics.from_xml_string(
            quadruped.make_model(floor_size=FLOOR_SIZE), common.ASSETS
        )
    return physics, quadruped.Move(desired_speed=WALK_SPEED, random=rng)


def _read(physics: Any) -> dict[str, np.ndarray | float]:
    return {
        "torso_upright": float(physics.torso_upright()),
        "torso_velocity": np.asarray(physics.torso_velocity(), dtype=np.float64),
        "com_height": float(physics.named.data.sensordata["center_of_mass"][2]),
    }


def _upright(q: Quantities) -> np.ndarray:
    # 1 when the torso's z axis points up, falling linearly to 0 upside down.
    return linear_tolerance(q["torso_upright"], 1.0, INF, 2.0, 0.0)


def _move(speed: float) -> Any:
    def reward(q: Quantities) -> np.ndarray:
        return _upright(q) * linear_tolerance(q["torso_velocity"][:, 0], speed, INF, speed, 0.5)

    return reward


def _jump(q: Quantities) -> np.ndarray:
    return _upright(q) * linear_tolerance(q["com_height"], JUMP_HEIGHT, INF, JUMP_HEIGHT, 0.5)


GYRO = slice(51, 54)  # the observation's imu gyro (after 44 joint, 3 velocity, 1 upright, 3 accel)


def _features(q: Quantities, obs: np.ndarray) -> dict[str, np.ndarray]:
    velocity = q["torso_velocity"]
    return {
        "com_height": q["com_height"],
        "torso_tilt": np.degrees(np.arccos(np.clip(q["torso_upright"], -1.0, 1.0))),
        "forward_velocity": velocity[:, 0],
        "horizontal_speed": np.linalg.norm(velocity[:, :2], axis=1),
        "angular_speed": np.linalg.norm(obs[:, GYRO], axis=1),
    }


# The observation has no root position or orientation: no frames of kept rollouts.
_LOCOMOTION = Locomotion(
    "quadruped",
    _features,
    {
        "com_height": "centre-of-mass height (m)",
        "torso_tilt": "torso tilt (deg, 0 = upright)",
        "forward_velocity": "forward velocity, torso frame (m/s)",
        "horizontal_speed": "horizontal speed, torso frame (m/s)",
        "angular_speed": "angular speed, gyro (rad/s)",
    },
)

_CUSTOM = "URLB/offline_rl quadruped"
_TASKS = [
    TaskSpec("stand", _upright, "keep the torso upright", _CUSTOM),
    TaskSpec("walk", _move(WALK_SPEED), "move forward at >= 0.5 m/s while upright", "dm_control"),
    TaskSpec("run", _move(RUN_SPEED), "move forward at >= 5 m/s while upright", "dm_control"),
    TaskSpec("jump", _jump, "raise the centre of mass to >= 1 m while upright", _CUSTOM),
]

DOMAIN = DomainSpec(
    name="quadruped",
    obs_dim=78,
    act_dim=12,
    physics_dim=57,
    control_timestep=0.02,
    quantity_shapes={"torso_upright": (), "torso_velocity": (3,), "com_height": ()},
    tasks={t.name: t for t in _TASKS},
    build=_build,
    read_quantities=_read,
    camera_id=2,
    hooks=_LOCOMOTION.hooks(),
)
