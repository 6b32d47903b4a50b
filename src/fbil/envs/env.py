"""A Gymnasium environment over one domain and one task.

Stepping follows dm_control's `control.Environment` (set the control, run the physics
sub-steps), but the reward comes from the task's vectorised function of the domain's
quantities, which is what makes relabeling exact (see `fbil.envs.relabel`).
"""

from __future__ import annotations

from typing import Any, SupportsFloat

import gymnasium as gym
import numpy as np

from fbil.envs.base import DomainSpec, Quantities, TaskSpec
from fbil.envs.registry import get_domain, get_task
from fbil.errors import FbilError


def stack_quantities(domain: DomainSpec, rows: list[dict[str, Any]]) -> Quantities:
    """List of per-state readings -> one array per quantity, shape (N, *shape)."""
    return {
        name: np.asarray([row[name] for row in rows], dtype=np.float64).reshape((len(rows), *shape))
        for name, shape in domain.quantity_shapes.items()
    }


class FbilEnv(gym.Env[np.ndarray, np.ndarray]):
    """Flat float32 observations, actions in [-1, 1], episodes truncated after 1000 steps.

    `info["physics"]` carries the physics state after each reset and step, which is what
    datasets store so that any task's reward can be recomputed later.
    """

    metadata = {"render_modes": ["rgb_array"]}  # noqa: RUF012 (gymnasium's convention)

    def __init__(
        self,
        domain: str,
        task: str,
        seed: int | None = None,
        render_size: tuple[int, int] = (240, 320),
    ) -> None:
        self.domain: DomainSpec = get_domain(domain)
        self.task: TaskSpec = get_task(domain, task)
        self.physics, self._init_task = self.domain.build(np.random.RandomState(seed))
        n_sub = self.domain.control_timestep / self.physics.timestep()
        self._n_sub_steps = round(n_sub)
        assert abs(n_sub - self._n_sub_steps) < 1e-9, "control step must be a multiple"
        self.render_mode = "rgb_array"
        self._render_size = render_size
        self.observation_space = gym.spaces.Box(
            -np.inf, np.inf, (self.domain.obs_dim,), dtype=np.float32
        )
        self.action_space = gym.spaces.Box(-1.0, 1.0, (self.domain.act_dim,), dtype=np.float32)
        self._t = 0
        self._needs_reset = True

    # -- gymnasium API ---------------------------------------------------------------
    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed)
        if seed is not None:
            # Initial states come from the dm_control task's own RNG.
            self._init_task._random = np.random.RandomState(seed)
        with self.physics.reset_context():
            self._init_task.initialize_episode(self.physics)
        self._t = 0
        self._needs_reset = False
        return self.observe(), {"physics": self.physics.get_state(), "step": 0}

    def step(
        self, action: np.ndarray
    ) -> tuple[np.ndarray, SupportsFloat, bool, bool, dict[str, Any]]:
        truncated = self.advance(action)
        info = {"physics": self.physics.get_state(), "step": self._t}
        return self.observe(), self.reward_now(), False, truncated, info

    def render(self) -> np.ndarray:
        h, w = self._render_size
        return np.asarray(self.physics.render(h, w, camera_id=self.domain.camera_id))

    # -- fbil extras -------------------------------------------------------------------
    @property
    def step_index(self) -> int:
        return self._t

    def advance(self, action: np.ndarray) -> bool:
        """Step the physics without computing the reward (the batched engine computes all
        environments' rewards in one vectorised call); returns whether the episode ended."""
        if self._needs_reset:
            raise FbilError("the episode has ended (or never started): call reset() first")
        action = self._check_action(action)
        self._init_task.before_step(action, self.physics)
        self.physics.step(self._n_sub_steps)
        self._init_task.after_step(self.physics)
        self._t += 1
        self._needs_reset = self._t >= self.domain.episode_length
        return self._needs_reset

    def reward_now(self) -> float:
        """The task's reward at the current physics state and control."""
        q = stack_quantities(self.domain, [self.domain.read_quantities(self.physics)])
        return float(self.task.reward(q)[0])

    def set_physics_state(self, state: np.ndarray) -> np.ndarray:
        """Put the episode in a given physics state (e.g. a shifted start); returns obs.

        Observation entries from acceleration-stage sensors (quadruped's accelerometer and
        toe force/torque) are recomputed at this state, whereas after a normal step they lag
        one step behind (dm_control's legacy stepping); everything else matches exactly.
        """
        state = np.asarray(state, dtype=np.float64)
        if state.shape != (self.domain.physics_dim,) or not np.all(np.isfinite(state)):
            raise FbilError(
                f"physics state must be {self.domain.physics_dim} finite numbers for "
                f"{self.domain.name}, got shape {state.shape}"
            )
        if self._needs_reset:
            self.reset()
        self.physics.set_state(state)
        self.physics.forward()
        return self.observe()

    def observe(self) -> np.ndarray:
        obs = self._init_task.get_observation(self.physics)
        return np.concatenate([np.asarray(v, dtype=np.float32).ravel() for v in obs.values()])

    def _check_action(self, action: np.ndarray) -> np.ndarray:
        a = np.asarray(action, dtype=np.float64)
        if a.shape != (self.domain.act_dim,):
            raise FbilError(
                f"action must have shape ({self.domain.act_dim},) for {self.domain.name}, "
                f"got {a.shape}"
            )
        if not np.all(np.isfinite(a)):
            raise FbilError(f"action contains NaN or inf: {a}")
        return np.clip(a, -1.0, 1.0)


def make_env(domain: str, task: str, seed: int | None = None) -> FbilEnv:
    """The one entry point: `make_env("walker", "run", seed=0)`."""
    return FbilEnv(domain, task, seed=seed)
