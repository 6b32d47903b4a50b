"""Reach demonstrations from a hand-written controller, not from a TD3 expert (issue #23).

A check that imitation scores do not lean on the committed demos: the point mass is steered
by a PD law (force towards the next waypoint, damped by its velocity) through the doorways
on the shortest route to the task's goal, then held at the goal with the push switched off
once it sits there at rest. Written for the five reach tasks of `point_mass_maze` (for
reach_bottom_left_long, clockwise the long way round, as its reward asks); every other task
is refused. The demos are saved in `fbil demos`' format (one npz per task, with
actions and physics), so `fbil imitate/evaluate/benchmark --demos DIR` read them as any.

Usage: python scripts/maze_controller_demos.py --out DIR [--episodes 20] [--seed 7]
           [--tasks reach_top_left,...]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from fbil.envs.rollout import BatchedEnv
from fbil.errors import FbilError
from fbil.imitation.demos import Demos, from_episodes

DOOR = 0.24  # doorway centres: (0, +-DOOR) and (+-DOOR, 0)
# Shortest route from the top-left (start) room to each goal, as waypoints.
ROUTES = {
    "reach_top_left": [(-0.15, 0.15)],
    "reach_top_right": [(-0.05, DOOR), (0.05, DOOR), (0.15, 0.15)],
    "reach_bottom_left": [(-DOOR, 0.05), (-DOOR, -0.05), (-0.15, -0.15)],
    "reach_bottom_right": [(-0.05, DOOR), (0.05, DOOR), (DOOR, 0.05), (DOOR, -0.05), (0.15, -0.15)],
    # The long way round that the task's reward asks for: clockwise through three doorways.
    "reach_bottom_left_long": [
        (-0.05, DOOR),
        (0.05, DOOR),
        (DOOR, 0.05),
        (DOOR, -0.05),
        (0.05, -DOOR),
        (-0.05, -DOOR),
        (-0.15, -0.15),
    ],
}
KP, KD = 40.0, 6.0  # push per metre of error, per m/s of velocity
PASS_RADIUS = 0.03  # a waypoint (not the goal) counts as passed within this distance
HOLD_RADIUS, HOLD_SPEED = 0.004, 0.01  # at the goal and this slow: push off


class WaypointController:
    """A batched policy for `BatchedEnv.rollout`: obs (n, 4) = position, velocity."""

    def __init__(self, route: list[tuple[float, float]], n: int) -> None:
        self.route = np.asarray(route, dtype=np.float64)
        self.next = np.zeros(n, dtype=int)

    def __call__(self, obs: np.ndarray, step: int) -> np.ndarray:
        pos, vel = obs[:, :2].astype(np.float64), obs[:, 2:4].astype(np.float64)
        last = len(self.route) - 1
        passed = (self.next < last) & (
            np.linalg.norm(pos - self.route[self.next], axis=1) < PASS_RADIUS
        )
        self.next = self.next + passed
        target = self.route[self.next]
        push = np.clip(KP * (target - pos) - KD * vel, -1.0, 1.0)
        at_goal = self.next == last
        resting = (
            at_goal
            & (np.linalg.norm(pos - target, axis=1) < HOLD_RADIUS)
            & (np.linalg.norm(vel, axis=1) < HOLD_SPEED)
        )
        push[resting] = 0.0
        return push.astype(np.float32)


def controller_demos(task: str, episodes: int, seed: int) -> Demos:
    if task not in ROUTES:
        raise FbilError(f"no controller route for {task!r}; valid: {', '.join(ROUTES)}")
    seeds = [seed * 1_000_003 + 300_000 + i for i in range(episodes)]
    env = BatchedEnv("point_mass_maze", task, episodes)
    ep = env.rollout(WaypointController(ROUTES[task], episodes), seeds)
    return from_episodes(
        ep,
        {
            "domain": "point_mass_maze",
            "task": task,
            "source": "hand-written waypoint PD controller (scripts/maze_controller_demos.py)",
            "start": "standard",
            "seed": seed,
        },
    )


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--out", required=True, help="folder for TASK.npz files")
    p.add_argument("--episodes", type=int, default=20)
    p.add_argument("--seed", type=int, default=7)
    p.add_argument("--tasks", default=",".join(ROUTES))
    args = p.parse_args(argv)
    try:
        if args.episodes < 1:
            raise FbilError(f"--episodes must be >= 1, got {args.episodes}")
        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        for task in [t.strip() for t in args.tasks.split(",") if t.strip()]:
            demos = controller_demos(task, args.episodes, args.seed)
            demos.save(out / f"{task}.npz")
            m = demos.metadata
            print(f"{task}: return {m['return_mean']:.1f} +- {m['return_std']:.1f}")
    except (FbilError, OSError) as exc:
        print(f"maze_controller_demos: error: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
