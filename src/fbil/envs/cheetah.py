"""cheetah: dm_control's half-cheetah, running and walking both ways."""

from __future__ import annotations

from typing import Any

import numpy as np
from dm_control.suite import cheetah

from fbil.envs.base import DomainSpec, Quantities, TaskSpec, linear_tolerance, quiet_model_compile

RUN_SPEED, WALK_SPEED = 10.0, 2.0


def _build(rng: np.random.RandomState) -> tuple[Any, Any]:
    with quiet_model_compile():
        physics = cheetah.Physics.from_xml_string(*cheetah.get_model_and_assets())
    return physics, cheetah.Cheetah(random=rng)


def _read(physics: Any) -> dict[str, np.ndarray | float]:
    return {"speed": float(physics.speed())}


def _speed(target: float, direction: float) -> Any:
    def reward(q: Quantities) -> np.ndarray:
        return linear_tolerance(direction * q["speed"], target, float("inf"), target, 0.0)

    return reward


_CUSTOM = "URLB/offline_rl cheetah"
_TASKS = [
    TaskSpec("run", _speed(RUN_SPEED, 1.0), "run forward at >= 10 m/s", "dm_control"),
    TaskSpec("run_backward", _speed(RUN_SPEED, -1.0), "run backward at >= 10 m/s", _CUSTOM),
    TaskSpec("walk", _speed(WALK_SPEED, 1.0), "move forward at >= 2 m/s", _CUSTOM),
    TaskSpec("walk_backward", _speed(WALK_SPEED, -1.0), "move backward at >= 2 m/s", _CUSTOM),
]

DOMAIN = DomainSpec(
    name="cheetah",
    obs_dim=17,
    act_dim=6,
    physics_dim=18,
    control_timestep=0.01,
    quantity_shapes={"speed": ()},
    tasks={t.name: t for t in _TASKS},
    build=_build,
    read_quantities=_read,
)
