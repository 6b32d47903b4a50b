"""point_mass_maze's hooks (see fbil.envs.hooks).

Starts: "uniform" anywhere on the free floor (data collection: with a cpu-sized budget,
RND from the standard top-left start leaves the bottom rooms' interiors unvisited) and
"shifted" in the top-right room (paper App. E.5). Coverage: the share of the free cells
of a 20 x 20 grid over the arena that the data visits (a cell is free when the mass's
centre can reach the cell's centre), overall and per room, and the doorway crossings: a
model learns how rooms connect only from transitions that change room, and full cell
coverage can come with very few of them. Oversampling: windows around those crossings.
Pictures: planar paths over the walls.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from fbil.envs.hooks import (
    Coverage,
    CoverageData,
    DomainHooks,
    Episode,
    ImitationPicture,
    Oversampling,
    Pictures,
    Policy,
    RenderRequest,
)
from fbil.envs.maze_geometry import (
    ARENA_HALF,
    JOINT_LIMIT,
    MASS_RADIUS,
    ROOMS,
    START_HIGH,
    START_LOW,
    in_inner_wall,
    random_free_positions,
    room_of,
)
from fbil.errors import FbilError

GRID = 20


# -- starts ------------------------------------------------------------------------------
def _at_rest(xy: np.ndarray) -> np.ndarray:
    return np.concatenate([xy, np.zeros((len(xy), 2))], axis=1)


def uniform_starts(
    seeds: Sequence[int], task: str | None = None, policy: Policy | None = None
) -> np.ndarray:
    """Anywhere on the free floor of the four rooms, at rest."""
    return _at_rest(random_free_positions(np.random.default_rng(seeds[0]), len(seeds)))


def shifted_starts(
    seeds: Sequence[int], task: str | None = None, policy: Policy | None = None
) -> np.ndarray:
    """In the top-right room (x, y > 0; the standard start is the top-left one), at rest."""
    rng = np.random.default_rng(seeds[0])
    return _at_rest(rng.uniform(START_LOW, START_HIGH, (len(seeds), 2)))


# -- coverage ----------------------------------------------------------------------------
def _cell_centres() -> np.ndarray:
    edges = np.linspace(-ARENA_HALF, ARENA_HALF, GRID + 1)
    return (edges[:-1] + edges[1:]) / 2


def free_cells() -> np.ndarray:
    """(GRID, GRID) bool, indexed [ix, iy]: cells whose centre the mass can reach."""
    cx, cy = np.meshgrid(_cell_centres(), _cell_centres(), indexing="ij")
    in_range = (np.abs(cx) <= JOINT_LIMIT) & (np.abs(cy) <= JOINT_LIMIT)
    # The '+' wall grown by the mass's radius: where the centre cannot go.
    wall = in_inner_wall(np.stack([cx, cy], -1), MASS_RADIUS, MASS_RADIUS)
    return in_range & ~wall


def visit_counts(xy: np.ndarray) -> np.ndarray:
    """(GRID, GRID) counts of positions per cell, indexed [ix, iy]."""
    edges = np.linspace(-ARENA_HALF, ARENA_HALF, GRID + 1)
    counts, _, _ = np.histogram2d(xy[:, 0], xy[:, 1], bins=[edges, edges])
    return counts


def maze_coverage(xy: np.ndarray) -> dict[str, Any]:
    free = free_cells()
    visited = (visit_counts(xy) > 0) & free
    centres = _cell_centres()
    cx, cy = np.meshgrid(centres, centres, indexing="ij")
    room = room_of(np.stack([cx, cy], axis=-1))
    per_room = {
        name: float(visited[room == i].sum() / free[room == i].sum())
        for i, name in enumerate(ROOMS)
    }
    return {
        "grid": f"{GRID}x{GRID}",
        "free_cells": int(free.sum()),
        "visited_cells": int(visited.sum()),
        "grid_fraction": float(visited.sum() / free.sum()),
        "rooms_visited": [name for name, frac in per_room.items() if frac > 0],
        "room_fraction": per_room,
    }


def doorway_crossings(dataset: CoverageData) -> dict[str, Any]:
    """Transitions whose state and next state lie in different rooms, per room pair."""
    j = dataset.next_index
    before = room_of(dataset.observation[j - 1, :2])
    after = room_of(dataset.observation[j, :2])
    moved = before != after
    pairs = np.zeros((4, 4), dtype=np.int64)
    np.add.at(pairs, (before[moved], after[moved]), 1)
    return {
        "transitions": int(moved.sum()),
        "per_episode": float(moved.sum() / max(dataset.num_episodes, 1)),
        "share": float(moved.mean()) if len(moved) else 0.0,
        "pairs": {
            f"{ROOMS[a]}->{ROOMS[b]}": int(pairs[a, b])
            for a in range(4)
            for b in range(4)
            if a != b and pairs[a, b]
        },
    }


def coverage_summary(dataset: CoverageData) -> dict[str, Any]:
    info = maze_coverage(dataset.observation[dataset.next_index, :2])
    info["doorway_crossings"] = doorway_crossings(dataset)
    return info


def coverage_text(cov: dict[str, Any]) -> list[str]:
    lines = [
        f"coverage: {100 * cov['grid_fraction']:.1f}% of {cov['free_cells']} free cells "
        f"({cov['grid']} grid); rooms visited: {', '.join(cov['rooms_visited'])}"
    ]
    lines += [f"  {room:<13} {100 * frac:5.1f}%" for room, frac in cov["room_fraction"].items()]
    return lines


def plot_coverage(dataset: CoverageData, cov: dict[str, Any], out: Path) -> Path:
    """Log-density heatmap of the visited positions over the walls."""
    from fbil.envs.render import _pyplot, _save, draw_maze

    xy = dataset.observation[dataset.next_index, :2]
    fig, ax = _pyplot().subplots(figsize=(4.8, 4.5), dpi=120)
    draw_maze(ax)
    edges = np.linspace(-ARENA_HALF, ARENA_HALF, 61)
    h, _, _ = np.histogram2d(xy[:, 0], xy[:, 1], bins=[edges, edges])
    masked = np.ma.masked_equal(h.T, 0)
    im = ax.pcolormesh(edges, edges, np.ma.log10(masked), cmap="viridis", zorder=1)
    fig.colorbar(im, ax=ax, fraction=0.046, label="log10 visits")
    ax.set_title(
        f"{dataset.num_episodes} episodes: {100 * cov['grid_fraction']:.0f}% of cells, "
        f"{len(cov['rooms_visited'])}/4 rooms",
        fontsize=9,
    )
    return _save(fig, out)


class GridTracker:
    """Share of the free cells visited so far, while collecting."""

    def __init__(self) -> None:
        self.counts = np.zeros((GRID, GRID))

    def update(self, observation: np.ndarray) -> None:
        self.counts += visit_counts(observation.reshape(-1, observation.shape[-1])[:, :2])

    def summary(self) -> str:
        free = free_cells()
        return f"{100 * ((self.counts > 0) & free).sum() / free.sum():.0f}% cells"


# -- oversampling ------------------------------------------------------------------------
def crossing_windows(episode: Episode, window: int) -> list[Episode]:
    """The rows [t - window - 1, t + window] around each row t reached by a room change, as
    episodes of their own (row 0 becomes the reset row: zero action and reward)."""
    room = room_of(episode["observation"][:, :2])
    reached = np.flatnonzero(room[1:] != room[:-1]) + 1
    out = []
    for t in reached:
        lo, hi = max(0, t - window - 1), min(len(room), t + window + 1)
        seg = {k: np.array(v[lo:hi]) for k, v in episode.items()}
        seg["action"][0] = 0
        seg["reward"][0] = 0
        out.append(seg)
    return out


# -- pictures ----------------------------------------------------------------------------
def render_paths(request: RenderRequest) -> list[float]:
    """`request.episodes` x-y paths over the walls (an image); returns their returns."""
    from fbil.envs.render import IMAGE_SUFFIXES, plot_maze_trajectories
    from fbil.envs.rollout import rollout

    if request.out.suffix.lower() not in IMAGE_SUFFIXES:
        raise FbilError("maze pictures are images: use .png, .pdf, .svg or .jpg")
    seeds = list(range(request.seed, request.seed + request.episodes))
    ran = rollout("point_mass_maze", request.task, request.policy, seeds, request.steps)
    plot_maze_trajectories(list(ran.observation), request.out, task=request.task)
    return [float(r) for r in ran.returns]


def keep_path(observation: np.ndarray, physics: np.ndarray | None = None) -> list[Any]:
    """The x-y path, every 2nd step, to 3 decimals (the observation holds it)."""
    return np.asarray(observation)[::2, :2].round(3).tolist()


def imitation_panels(picture: ImitationPicture) -> Path:
    from fbil.envs.render import plot_imitation_panels

    titles = dict(picture.titles) if picture.titles else None
    rollouts = dict(picture.rollouts)
    return plot_imitation_panels(
        picture.demo_observation, rollouts, picture.out, picture.task, titles
    )


HOOKS = DomainHooks(
    starts={"uniform": uniform_starts, "shifted": shifted_starts},
    coverage=Coverage(coverage_summary, coverage_text, plot_coverage, GridTracker),
    oversampling=Oversampling(
        "doorway crossings", "transition that changes room", crossing_windows
    ),
    pictures=Pictures(
        render=render_paths,
        keep=keep_path,
        imitation=imitation_panels,
        imitation_heading="Demonstration (red) against each method's rollout (green)",
    ),
    demo_task="loop",  # a path to follow, where the principles visibly differ
)
