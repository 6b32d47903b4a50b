"""Rewards after the fact, from stored physics states and actions.

Restoring a physics state does not restore the control, and the maze's reach reward
pays for small controls: each state is restored, its control set from the stored action,
and MuJoCo's forward pass recomputes every derived quantity before it is read.
The quantities of a dataset serve all of the domain's tasks, so compute them once.
"""

from __future__ import annotations

import numpy as np

from fbil.envs.base import Quantities
from fbil.envs.env import stack_quantities
from fbil.envs.registry import get_domain, get_task
from fbil.errors import FbilError


def compute_quantities(domain: str, physics: np.ndarray, actions: np.ndarray) -> Quantities:
    """Quantities of N transitions: `physics` (N, physics_dim) after each step, `actions`
    (N, act_dim) the action taken in that step."""
    spec = get_domain(domain)
    physics = np.asarray(physics, dtype=np.float64)
    actions = np.asarray(actions, dtype=np.float64)
    if physics.ndim != 2 or physics.shape[1] != spec.physics_dim:
        raise FbilError(
            f"physics states must have shape (N, {spec.physics_dim}) for {domain}, "
            f"got {physics.shape}"
        )
    if actions.shape != (physics.shape[0], spec.act_dim):
        raise FbilError(
            f"actions must have shape ({physics.shape[0]}, {spec.act_dim}) for {domain}, "
            f"got {actions.shape}"
        )
    sim, _ = spec.build(np.random.RandomState(0))
    actions = np.clip(actions, -1.0, 1.0)
    rows = []
    for state, action in zip(physics, actions, strict=True):
        sim.set_state(state)
        sim.set_control(action)
        sim.forward()
        rows.append(spec.read_quantities(sim))
    return stack_quantities(spec, rows)


def task_reward(domain: str, task: str, quantities: Quantities) -> np.ndarray:
    """Vectorised reward of `task` on precomputed quantities, shape (N,)."""
    return np.asarray(get_task(domain, task).reward(quantities), dtype=np.float64)


def relabel(domain: str, task: str, physics: np.ndarray, actions: np.ndarray) -> np.ndarray:
    """Reward of `task` for each stored transition, equal to the reward seen online."""
    return task_reward(domain, task, compute_quantities(domain, physics, actions))
