"""walker: dm_control's planar walker (stand, walk, run) plus flip and spin."""

from __future__ import annotations

from typing import Any

import numpy as np
from dm_control.suite import walker
from dm_control.utils import rewards

from fbil.envs.base import DomainSpec, Quantities, TaskSpec, linear_tolerance, quiet_model_compile
from fbil.envs.locomotion import Locomotion, wrap_angle

STAND_HEIGHT = 1.2  # dm_control's walker: torso height above which standing pays 1
WALK_SPEED, RUN_SPEED = 1.0, 8.0
FLIP_MOMENTUM, SPIN_MOMENTUM = 5.0, 10.0
INF = float("inf")
TORSO_Z = 1.3  # the torso body's height in the model, where the root joints sit
# Parent body of each of the 6 leg bodies, in the model's order after the torso:
# right thigh, leg, foot, left thigh, leg, foot (body 0 is the torso).
_PARENT = [0, 1, 2, 0, 4, 5]


def _build(rng: np.random.RandomState) -> tuple[Any, Any]:
    with quiet_model_compile():
        physics = walker.Physics.from_xml_string(*walker.get_model_and_assets())
    return physics, walker.PlanarWalker(move_speed=0, random=rng)


def _read(physics: Any) -> dict[str, np.ndarray | float]:
    return {
        "torso_height": float(physics.torso_height()),
        "torso_upright": float(physics.torso_upright()),
        "horizontal_velocity": float(physics.horizontal_velocity()),
        # Angular momentum of the torso subtree about the y axis (the plane's normal).
        "angular_momentum": float(physics.named.data.subtree_angmom["torso"][1]),
    }


def _stand(q: Quantities) -> np.ndarray:
    standing = rewards.tolerance(
        q["torso_height"], bounds=(STAND_HEIGHT, INF), margin=STAND_HEIGHT / 2
    )
    upright = (1 + q["torso_upright"]) / 2
    return np.asarray((3 * standing + upright) / 4)


def _move(speed: float) -> Any:
    def reward(q: Quantities) -> np.ndarray:
        move = linear_tolerance(q["horizontal_velocity"], speed, INF, speed / 2, 0.5)
        return _stand(q) * (5 * move + 1) / 6

    return reward


def _flip(q: Quantities) -> np.ndarray:
    rotate = linear_tolerance(q["angular_momentum"], FLIP_MOMENTUM, INF, FLIP_MOMENTUM, 0.0)
    return _stand(q) * (5 * rotate + 1) / 6


def _spin(q: Quantities) -> np.ndarray:
    return linear_tolerance(q["angular_momentum"], SPIN_MOMENTUM, INF, SPIN_MOMENTUM, 0.0)


def _features(q: Quantities, obs: np.ndarray) -> dict[str, np.ndarray]:
    return {
        "torso_height": q["torso_height"],
        # The torso's pitch from its rotation matrix (xx, xz): the observation's first pair.
        "torso_angle": np.degrees(np.arctan2(obs[:, 1], obs[:, 0])),
        "horizontal_velocity": q["horizontal_velocity"],
        "angular_momentum": q["angular_momentum"],
    }


def physics_from_observation(obs: np.ndarray) -> np.ndarray:
    """Physics states (qpos, qvel) behind (N, 24) observations, the horizontal position
    (which the tracking camera ignores) set to 0. Each body's pitch is atan2(xz, xx) of its
    orientation pair; a leg joint turns about -y, so its angle is parent minus child."""
    pitch = np.arctan2(obs[:, 1:14:2], obs[:, 0:14:2])
    joints = wrap_angle(pitch[:, _PARENT] - pitch[:, 1:])
    root = np.stack([obs[:, 14] - TORSO_Z, np.zeros(len(obs)), pitch[:, 0]], axis=1)
    return np.concatenate([root, joints, obs[:, 15:24]], axis=1)


_LOCOMOTION = Locomotion(
    "walker",
    _features,
    {
        "torso_height": "torso height (m)",
        "torso_angle": "torso angle (deg, 0 = upright)",
        "horizontal_velocity": "horizontal velocity (m/s)",
        "angular_momentum": "angular momentum about y",
    },
    physics_from_observation,
    # From the true-reward oracles' curves (docs/baselines.md, sessions 47-48): TD3 within
    # 90 % of its best at 250 000 updates, SAC at 200 000.
    baseline_budgets={
        **dict.fromkeys(("td3il", "oril", "oril_o", "oril_oo", "otr"), "cpu@5"),
        **dict.fromkeys(("sqil", "iqlearn"), "cpu,sac.steps=200000"),
    },
)

_URLB = "URLB walker (flip) / offline_rl walker (spin)"
_TASKS = [
    TaskSpec("stand", _stand, "stand upright with the torso high", "dm_control"),
    TaskSpec("walk", _move(WALK_SPEED), "walk forward at >= 1 m/s while upright", "dm_control"),
    TaskSpec("run", _move(RUN_SPEED), "run forward at >= 8 m/s while upright", "dm_control"),
    TaskSpec("flip", _flip, "rotate (angular momentum >= 5) while standing", _URLB),
    TaskSpec("spin", _spin, "rotate with angular momentum >= 10", _URLB),
]

DOMAIN = DomainSpec(
    name="walker",
    obs_dim=24,
    act_dim=6,
    physics_dim=18,
    control_timestep=0.025,
    quantity_shapes={
        "torso_height": (),
        "torso_upright": (),
        "horizontal_velocity": (),
        "angular_momentum": (),
    },
    tasks={t.name: t for t in _TASKS},
    build=_build,
    read_quantities=_read,
    hooks=_LOCOMOTION.hooks(),
)
