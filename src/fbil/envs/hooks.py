"""Domain hooks: what a domain does differently from the others, behind one interface.

Generic code (collection, dataset summaries, oversampling, expert demonstrations, the
benchmark and its report) never asks a domain's name: it asks the domain's hooks, and a
hook the domain leaves out means "not defined here". The maze's hooks live in
`fbil.envs.maze_hooks`, the locomotion domains' (shared) in `fbil.envs.locomotion`.

- `starts`: initial-state variants beyond the domain's own ("standard"), by name; each
  returns physics states to move freshly reset episodes to (paper App. E.5 for "shifted").
- `coverage`: the dataset coverage summary (JSON-ready), its lines for a terminal, its
  picture, and a running one-liner shown while collecting.
- `oversampling`: windows cut around a domain's rare, informative transitions.
- `pictures`: `fbil render`'s picture of a policy, and the report's picture of a
  demonstration against each imitation method's rollout.
- `baseline_budgets`: the training budget measured for a baseline on this domain (method
  -> budget spec, from its true-reward oracle's curve), which `--budget auto` picks.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

import numpy as np

# policy(obs (N, obs_dim) float32, steps already taken) -> actions (N, act_dim) in [-1, 1]
Policy = Callable[[np.ndarray, int], np.ndarray]
# One stored episode: field name -> (T+1, width) array (fbil.data.storage's layout).
Episode = dict[str, np.ndarray]
# (seeds, task or None, policy or None) -> (len(seeds), physics_dim) physics states.
StartFn = Callable[[Sequence[int], str | None, Policy | None], np.ndarray]


class CoverageData(Protocol):
    """What a coverage summary reads of a dataset (`fbil.data.Dataset` has all of it)."""

    domain: str
    observation: np.ndarray  # (rows, obs_dim), the reset rows included
    action: np.ndarray  # (rows, act_dim)
    next_index: np.ndarray  # the rows that end a transition

    @property
    def num_episodes(self) -> int: ...

    @property
    def num_transitions(self) -> int: ...

    def physics(self) -> np.ndarray: ...

    def quantities(self) -> dict[str, np.ndarray]: ...


class RunningCoverage(Protocol):
    """Coverage so far, while collecting: fed every batch of episodes."""

    def update(self, observation: np.ndarray) -> None: ...

    def summary(self) -> str: ...


@dataclass(frozen=True)
class Coverage:
    """How far a dataset covers the domain."""

    summary: Callable[[CoverageData], dict[str, Any]]  # JSON-ready
    text: Callable[[dict[str, Any]], list[str]]  # that summary, as lines for a terminal
    plot: Callable[[CoverageData, dict[str, Any], Path], Path]  # its picture
    tracker: Callable[[], RunningCoverage] | None = None


@dataclass(frozen=True)
class Oversampling:
    """Rare transitions worth more weight, and the episode windows around them."""

    what: str  # a plural noun for manifests, e.g. "doorway crossings"
    event: str  # one of them, described, e.g. "transition that changes room"
    windows: Callable[[Episode, int], list[Episode]]  # (episode, half-width) -> windows


@dataclass(frozen=True)
class RenderRequest:
    """`fbil render`: episodes of `policy` on `task`, drawn to `out`."""

    task: str
    policy: Policy
    seed: int
    episodes: int  # how many (where the picture shows several, e.g. the maze's paths)
    steps: int | None  # steps per episode (None: the domain's default)
    frames: int  # frames of a strip (locomotion images)
    out: Path


@dataclass(frozen=True)
class ImitationPicture:
    """The report's picture: a demonstration (its observations and, when stored, physics
    states) against what `Pictures.keep` kept of each method's rollout."""

    demo_observation: np.ndarray
    demo_physics: np.ndarray | None
    rollouts: Mapping[str, np.ndarray]  # method -> kept rollout
    out: Path
    task: str
    titles: Mapping[str, str] | None = None  # method -> title (default: its name)


@dataclass(frozen=True)
class Pictures:
    # Draws the request; returns the returns of the episodes drawn (empty where the
    # picture shows no return).
    render: Callable[[RenderRequest], list[float]]
    # Observations (T+1, obs_dim) and, where recorded, physics states (T+1, physics_dim)
    # of an evaluation episode -> what a benchmark row keeps of it for the report's
    # picture (JSON-ready, small), or None to keep nothing.
    keep: Callable[[np.ndarray, np.ndarray | None], list[Any] | None]
    imitation: Callable[[ImitationPicture], Path | None]  # None: nothing to draw
    imitation_heading: str  # the report's heading over those pictures


@dataclass(frozen=True)
class DomainHooks:
    starts: Mapping[str, StartFn] = field(default_factory=dict)
    coverage: Coverage | None = None
    oversampling: Oversampling | None = None
    pictures: Pictures | None = None
    baseline_budgets: Mapping[str, str] = field(default_factory=dict)
    # the task `fbil demo` imitates when none is named (None: its first committed demo)
    demo_task: str | None = None
