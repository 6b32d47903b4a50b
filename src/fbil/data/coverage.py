"""How much of the environment a dataset covers.

Every dataset gets its size, observation ranges and state-norm spread; the domain's
coverage hook (fbil.envs.hooks) adds what tells whether the data is diverse enough for
its tasks (the maze: grid cells and doorway crossings; locomotion: torso height,
orientation, speed and rotation against random actions), and draws it.
"""

from __future__ import annotations

import weakref
from pathlib import Path
from typing import Any

import numpy as np

from fbil.data.dataset import Dataset
from fbil.envs import get_domain
from fbil.envs.hooks import RunningCoverage
from fbil.errors import FbilError

# The domain's summary per dataset object: `fbil dataset-info --plot` summarises, then
# draws the same summary, and a locomotion summary takes seconds.
_SUMMARIES: weakref.WeakKeyDictionary[Dataset, dict[str, Any]] = weakref.WeakKeyDictionary()


class NormSpread:
    """Spread of observation norms so far: a coverage one-liner for any domain."""

    def __init__(self) -> None:
        self.norms: list[float] = []

    def update(self, observation: np.ndarray) -> None:
        obs = observation.reshape(-1, observation.shape[-1])
        self.norms.extend(np.linalg.norm(obs[::50], axis=1).tolist())

    def summary(self) -> str:
        return f"|s| std {np.std(self.norms):.2f}" if self.norms else ""


def coverage_tracker(domain: str) -> RunningCoverage:
    """The domain's running coverage while collecting (observation-norm spread where the
    domain defines none)."""
    coverage = get_domain(domain).hooks.coverage
    if coverage is not None and coverage.tracker is not None:
        return coverage.tracker()
    return NormSpread()


def domain_coverage(dataset: Dataset) -> dict[str, Any] | None:
    """The domain's coverage summary of `dataset` (None where the domain defines none)."""
    coverage = get_domain(dataset.domain).hooks.coverage
    if coverage is None:
        return None
    if dataset not in _SUMMARIES:
        _SUMMARIES[dataset] = coverage.summary(dataset)
    return _SUMMARIES[dataset]


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
    coverage = domain_coverage(dataset)
    if coverage is not None:
        info["coverage"] = coverage
    return info


def coverage_text(info: dict[str, Any]) -> list[str]:
    """`dataset_info`'s coverage as lines for a terminal (none without a coverage)."""
    coverage = get_domain(info["domain"]).hooks.coverage
    if coverage is None or "coverage" not in info:
        return []
    return coverage.text(info["coverage"])


def plot_coverage(dataset: Dataset, out: str | Path) -> Path:
    """The domain's coverage picture (e.g. the maze's visit heatmap over the walls,
    locomotion's feature histograms against random actions)."""
    coverage = get_domain(dataset.domain).hooks.coverage
    summary = domain_coverage(dataset)
    if coverage is None or summary is None:
        raise FbilError(f"{dataset.domain} defines no coverage picture")
    return coverage.plot(dataset, summary, Path(out))
