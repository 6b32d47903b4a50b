"""walker: dm_control's planar walker (stand, walk, run) plus flip and spin."""

from __future__ import annotations

from typing import Any

import numpy as np
from dm_control.suite import walker
from dm_control.utils import rewards

from fbil.envs.base import DomainSpec, Quantities, TaskSpec, linear_tolerance, quiet_model_compile

STAND_HEIGHT = 1.2  # dm_control's walker: torso height above which standing pays 1
WALK_SPEED, RUN_SPEED = 1.0, 8.0
FLIP_MOMENTUM, SPIN_MOMENTUM = 5.0, 10.0
INF = float("inf")


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
)
