"""What a domain and a task are.

A *domain* is one MuJoCo model plus the dm_control task object that draws its initial
states and builds its observations. A *task* is only a reward: a vectorised function of a
few physical quantities that the domain reads off a physics state (and the applied
control). Splitting it this way makes every reward computable after the fact, from stored
physics states, for any dataset: online stepping and offline relabeling call the very same
function on the very same quantities.
"""

from __future__ import annotations

import contextlib
import logging
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from fbil.envs.hooks import DomainHooks, Policy
from fbil.errors import FbilError

# Named arrays, one row per state: shape (N,) or (N, k).
Quantities = dict[str, np.ndarray]
RewardFn = Callable[[Quantities], np.ndarray]


@dataclass(frozen=True)
class TaskSpec:
    """One reward over a domain's quantities."""

    name: str
    reward: RewardFn
    description: str
    source: str  # "dm_control" or the custom suite the definition follows
    # Only for pictures of the maze: the goal and the route the reward asks for.
    goal: tuple[float, float] | None = None
    path: tuple[tuple[float, float], ...] | None = None
    # An upper bound of the reward of one step, for any state and control (every task here
    # is a product or mean of tolerances in [0, 1]; tested on random quantities). Times the
    # episode length it bounds any policy's return: `fbil.envs.max_return`.
    reward_max: float = 1.0


@dataclass(frozen=True)
class DomainSpec:
    """A physical system shared by several tasks."""

    name: str
    obs_dim: int
    act_dim: int
    physics_dim: int
    control_timestep: float
    # name -> trailing shape of the quantity (() for scalars)
    quantity_shapes: Mapping[str, tuple[int, ...]]
    tasks: Mapping[str, TaskSpec]
    # rng -> (physics, dm_control task drawing initial states and observations)
    build: Callable[[np.random.RandomState], tuple[Any, Any]]
    # physics -> this state's quantities, each of its trailing shape
    read_quantities: Callable[[Any], dict[str, np.ndarray | float]]
    episode_length: int = 1000
    camera_id: int = 0
    # What differs between domains beyond the physics: start variants, coverage summary,
    # oversampling, pictures (see fbil.envs.hooks). Generic code asks these, never a name.
    hooks: DomainHooks = field(default_factory=DomainHooks)

    @property
    def task_names(self) -> list[str]:
        return list(self.tasks)

    def start_states(
        self,
        variant: str,
        seeds: Sequence[int],
        task: str | None = None,
        policy: Policy | None = None,
    ) -> np.ndarray | None:
        """(len(seeds), physics_dim) physics states to start episodes from, for start
        `variant`; None for "standard" (the domain's own initial-state distribution)."""
        if variant == "standard":
            return None
        draw = self.hooks.starts.get(variant)
        if draw is None:
            valid = ", ".join(["standard", *self.hooks.starts])
            raise FbilError(f"start {variant!r} is not defined for {self.name}; valid: {valid}")
        states = np.asarray(draw(seeds, task, policy), dtype=np.float64)
        return states.reshape(len(seeds), self.physics_dim)


def linear_tolerance(
    x: np.ndarray, low: float, high: float, margin: float, value_at_margin: float = 0.0
) -> np.ndarray:
    """dm_control's `rewards.tolerance` with a linear sigmoid, on arrays."""
    from dm_control.utils import rewards

    return np.asarray(
        rewards.tolerance(
            x,
            bounds=(low, high),
            margin=margin,
            value_at_margin=value_at_margin,
            sigmoid="linear",
        )
    )


@contextlib.contextmanager
def quiet_model_compile() -> Iterator[None]:
    """Silence absl warnings while compiling dm_control's XML: newer MuJoCo warns about a
    deprecated attribute at every compile, which tells fbil users nothing they can act on."""
    logger = logging.getLogger("absl")
    level = logger.level
    logger.setLevel(logging.ERROR)
    try:
        yield
    finally:
        logger.setLevel(level)
