"""How much of the environment a dataset covers.

Maze: the share of the free cells of a 20 x 20 grid over the arena that the data visits
(a cell is free when the mass's centre can reach the cell's centre), overall and per room,
and the doorway crossings: a model learns how rooms connect only from transitions that
change room, and full cell coverage can come with very few of them.
Locomotion: ranges and spread of the observations, and histograms of the physical
quantities the tasks reward (torso height, forward velocity, angular momentum, ...).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from fbil.data.dataset import Dataset
from fbil.envs import compute_quantities, maze

GRID = 20
_REACH = maze.JOINT_LIMIT


def _cell_centres() -> np.ndarray:
    edges = np.linspace(-maze.ARENA_HALF, maze.ARENA_HALF, GRID + 1)
    return (edges[:-1] + edges[1:]) / 2


def free_cells() -> np.ndarray:
    """(GRID, GRID) bool, indexed [ix, iy]: cells whose centre the mass can reach."""
    cx, cy = np.meshgrid(_cell_centres(), _cell_centres(), indexing="ij")
    in_range = (np.abs(cx) <= _REACH) & (np.abs(cy) <= _REACH)
    # The '+' wall grown by the mass's radius: where the centre cannot go.
    wall = maze.in_inner_wall(np.stack([cx, cy], -1), maze.MASS_RADIUS, maze.MASS_RADIUS)
    return in_range & ~wall


def visit_counts(xy: np.ndarray) -> np.ndarray:
    """(GRID, GRID) counts of positions per cell, indexed [ix, iy]."""
    edges = np.linspace(-maze.ARENA_HALF, maze.ARENA_HALF, GRID + 1)
    counts, _, _ = np.histogram2d(xy[:, 0], xy[:, 1], bins=[edges, edges])
    return counts


def maze_coverage(xy: np.ndarray) -> dict[str, Any]:
    free = free_cells()
    visited = (visit_counts(xy) > 0) & free
    centres = _cell_centres()
    cx, cy = np.meshgrid(centres, centres, indexing="ij")
    room = maze.room_of(np.stack([cx, cy], axis=-1))
    per_room = {
        name: float(visited[room == i].sum() / free[room == i].sum())
        for i, name in enumerate(maze.ROOMS)
    }
    return {
        "grid": f"{GRID}x{GRID}",
        "free_cells": int(free.sum()),
        "visited_cells": int(visited.sum()),
        "grid_fraction": float(visited.sum() / free.sum()),
        "rooms_visited": [name for name, frac in per_room.items() if frac > 0],
        "room_fraction": per_room,
    }


def doorway_crossings(dataset: Dataset) -> dict[str, Any]:
    """Transitions whose state and next state lie in different rooms, per room pair."""
    j = dataset.next_index
    before = maze.room_of(dataset.observation[j - 1, :2])
    after = maze.room_of(dataset.observation[j, :2])
    moved = before != after
    pairs = np.zeros((4, 4), dtype=np.int64)
    np.add.at(pairs, (before[moved], after[moved]), 1)
    return {
        "transitions": int(moved.sum()),
        "per_episode": float(moved.sum() / max(dataset.num_episodes, 1)),
        "share": float(moved.mean()) if len(moved) else 0.0,
        "pairs": {
            f"{maze.ROOMS[a]}->{maze.ROOMS[b]}": int(pairs[a, b])
            for a in range(4)
            for b in range(4)
            if a != b and pairs[a, b]
        },
    }


class CoverageTracker:
    """Running coverage while collecting: maze grid share, or observation-norm spread."""

    def __init__(self, domain: str) -> None:
        self.domain = domain
        self.counts = np.zeros((GRID, GRID))
        self.norms: list[float] = []

    def update(self, observation: np.ndarray) -> None:
        obs = observation.reshape(-1, observation.shape[-1])
        if self.domain == "point_mass_maze":
            self.counts += visit_counts(obs[:, :2])
        else:
            self.norms.extend(np.linalg.norm(obs[::50], axis=1).tolist())

    def summary(self) -> str:
        if self.domain == "point_mass_maze":
            free = free_cells()
            frac = ((self.counts > 0) & free).sum() / free.sum()
            return f"{100 * frac:.0f}% cells"
        return f"|s| std {np.std(self.norms):.2f}" if self.norms else ""


def _sample_rows(dataset: Dataset, max_states: int) -> np.ndarray:
    rows = dataset.next_index
    if len(rows) > max_states:
        rows = np.sort(np.random.default_rng(0).choice(rows, max_states, replace=False))
    return rows


def locomotion_quantities(dataset: Dataset, max_states: int = 50_000) -> dict[str, np.ndarray]:
    """The domain's reward quantities on (a subsample of) the dataset's states, flattened
    into scalars (e.g. torso_velocity -> torso_velocity_x/_y/_z)."""
    rows = _sample_rows(dataset, max_states)
    if len(rows) == dataset.num_transitions:
        q = dataset.quantities()
    else:
        q = compute_quantities(dataset.domain, dataset.physics()[rows], dataset.action[rows])
    flat: dict[str, np.ndarray] = {}
    for name, values in q.items():
        if values.ndim == 1:
            flat[name] = values
        else:
            for k in range(values.shape[1]):
                flat[f"{name}_{'xyz'[k] if values.shape[1] <= 3 else k}"] = values[:, k]
    return flat


def dataset_info(dataset: Dataset) -> dict[str, Any]:
    obs = dataset.observation[dataset.next_index]
    info: dict[str, Any] = {
        "root": str(dataset.root),
        "domain": dataset.domain,
        "episodes": dataset.num_episodes,
        "transitions": dataset.num_transitions,
        "observation_min": obs.min(axis=0).round(4).tolist(),
        "observation_max": obs.max(axis=0).round(4).tolist(),
        "action_mean_abs": float(np.abs(dataset.action[dataset.next_index]).mean()),
    }
    norms = np.linalg.norm(obs, axis=1)
    info["state_norm"] = {
        "mean": float(norms.mean()),
        "std": float(norms.std()),
        "p01": float(np.percentile(norms, 1)),
        "p99": float(np.percentile(norms, 99)),
    }
    if dataset.domain == "point_mass_maze":
        info["coverage"] = maze_coverage(obs[:, :2])
        info["coverage"]["doorway_crossings"] = doorway_crossings(dataset)
    else:
        quantities = locomotion_quantities(dataset)
        info["coverage"] = {
            name: {
                "min": float(v.min()),
                "p01": float(np.percentile(v, 1)),
                "median": float(np.median(v)),
                "p99": float(np.percentile(v, 99)),
                "max": float(v.max()),
            }
            for name, v in quantities.items()
        }
        info["coverage"]["states_used"] = len(next(iter(quantities.values())))
    return info


def plot_coverage(dataset: Dataset, out: str | Path) -> Path:
    """Maze: log-density heatmap over the walls. Locomotion: quantity histograms."""
    from fbil.envs.render import _pyplot, _save, draw_maze

    plt = _pyplot()
    if dataset.domain == "point_mass_maze":
        xy = dataset.observation[dataset.next_index, :2]
        cov = maze_coverage(xy)
        fig, ax = plt.subplots(figsize=(4.8, 4.5), dpi=120)
        draw_maze(ax)
        edges = np.linspace(-maze.ARENA_HALF, maze.ARENA_HALF, 61)
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
    quantities = locomotion_quantities(dataset)
    fig, axes = plt.subplots(1, len(quantities), figsize=(3 * len(quantities), 2.6), dpi=120)
    for ax, (name, v) in zip(np.atleast_1d(axes), quantities.items(), strict=True):
        ax.hist(v, bins=60, color="#5e81ac")
        ax.set_title(name, fontsize=9)
        ax.set_yscale("log")
    fig.suptitle(f"{dataset.domain}: {dataset.num_episodes} episodes", fontsize=10)
    fig.tight_layout()
    return _save(fig, out)
