"""The one imitator interface: demonstrations (plus, for imitators that train, the
unsupervised dataset and a budget) in, a policy that acts on a batch of observations out.

Every imitation algorithm, whatever its family, is an `Imitator`; `fit` times it the same
way for all: wall seconds from demonstrations in memory (and any model or dataset already
loaded) to a policy that can act.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Protocol, runtime_checkable

import numpy as np

from fbil.errors import FbilError
from fbil.imitation.demos import Demos
from fbil.imitators.budgets import AUTO, parse_budget, resolve_auto, split_settings

# fb-il: through a pre-trained FB model, in seconds; offline-il: trained from scratch on
# the demos (and the unsupervised dataset); bfm: through another behaviour foundation model.
FAMILIES = ("fb-il", "offline-il", "bfm")


@runtime_checkable
class Policy(Protocol):
    """An imitation policy: `act(obs[N, obs_dim], step) -> actions[N, act_dim]` in
    [-1, 1] (`step`: steps already taken in the episode; without it, the policy's own
    counter, which `reset()` sets back to 0)."""

    suffix: str  # file type of `save` (".json", ".safetensors")

    def act(self, obs: np.ndarray, step: int | None = None) -> np.ndarray: ...

    def reset(self) -> None: ...

    def describe(self) -> dict[str, Any]: ...  # a JSON-able summary for `fbil imitate`

    def save(self, path: str | Path) -> Path: ...


@dataclass(frozen=True)
class FitContext:
    """What an imitator may use besides the demonstrations: the FB model (fb-il), the
    unsupervised dataset and a named budget (imitators that train), seed and threads, and
    a pre-trained goal model (goal-based BFMs)."""

    model: Any = None
    dataset: Any = None
    # `auto`, a named budget or NAME@SCALE, then ,PATH=VALUE (fbil.imitators.budgets)
    budget: str = AUTO
    seed: int = 0
    threads: int = 1
    optimiser: Any = None  # fb-il: the z optimiser (None: its default)
    goal_model: Any = None  # goal-based BFMs (goal_td3): the pre-trained goal model
    # Imitators that train for minutes: a `fbil.checkpoint.FitCheckpoint` their training
    # loop saves to and resumes from (`fbil benchmark` gives one to each job); None: none.
    checkpoint: Any = None


@dataclass(frozen=True)
class Fitted:
    name: str
    policy: Policy
    seconds: float  # time to policy


@dataclass(frozen=True)
class Imitator:
    name: str
    family: str
    principle: str  # the IL principle, as the report names it
    fit_policy: Callable[[Demos, FitContext], Policy]
    needs_actions: bool = False
    needs_dataset: bool = False
    needs_model: bool = False
    needs_goal_model: bool = False
    # Named budgets of imitators that train; a context's budget is one of them or a
    # scaled one, NAME@SCALE (fbil.imitators.budgets).
    budgets: Sequence[str] = ()
    # The settings a results line records for this imitator under `context`.
    settings: Callable[[FitContext], dict[str, Any]] = field(default=lambda _: {})

    def __post_init__(self) -> None:
        assert self.family in FAMILIES, self.family

    def resolved(self, context: FitContext, domain: str | None = None) -> FitContext:
        """`context` with an `auto` budget replaced by the one measured for this method on
        `domain` (default: the dataset's; `fbil.imitators.budgets.resolve_auto`)."""
        if not self.budgets:
            return context
        domain = domain or getattr(context.dataset, "domain", None)
        spec = resolve_auto(context.budget, self.name, domain)
        return context if spec == context.budget else replace(context, budget=spec)

    def require(self, context: FitContext) -> None:
        """One-line errors for inputs this imitator needs and `context` lacks."""
        context = self.resolved(context)
        if self.needs_dataset and context.dataset is None:
            raise FbilError(
                f"{self.name} trains on the unsupervised dataset: pass --data DIR "
                "(a dataset of the demonstrations' domain)"
            )
        if self.needs_model and context.model is None:
            raise FbilError(f"{self.name} imitates through an FB model: pass the model folder")
        if self.needs_goal_model and context.goal_model is None:
            raise FbilError(
                f"{self.name} imitates through a pre-trained goal model: pass --goal-model DIR "
                "(train one with `fbil pretrain-goal`)"
            )
        if self.budgets:
            parse_budget(context.budget, self.budgets, self.name)  # a name or NAME@SCALE
            try:  # resolving the budget checks its changed settings against this method's
                self.settings(context)
            except FbilError as exc:
                raise FbilError(f"budget {context.budget!r} for {self.name}: {exc}") from None

    def check(self, demos: Demos, context: FitContext) -> None:
        """One-line errors for what this imitator cannot work with."""
        context = self.resolved(context, demos.metadata.get("domain"))
        if self.needs_actions and not demos.has_actions:
            raise FbilError(
                f"{self.name} needs expert actions, and these demonstrations have none; "
                "use an action-free method (e.g. erfb, goalfb, oril_o)"
            )
        self.require(context)
        if self.needs_dataset:
            check_dataset(demos, context.dataset)
        if self.needs_goal_model:
            check_goal_model(demos, context.goal_model)

    def fit(self, demos: Demos, context: FitContext) -> Fitted:
        """Check, then fit and time: the seconds are the time to policy."""
        context = self.resolved(context, demos.metadata.get("domain"))
        self.check(demos, context)
        started = time.perf_counter()
        if context.checkpoint is not None:
            context.checkpoint.begin()
        policy = self.fit_policy(demos, context)
        if context.checkpoint is not None:  # a resumed fit counts its earlier processes' time
            return Fitted(self.name, policy, context.checkpoint.seconds())
        return Fitted(self.name, policy, time.perf_counter() - started)


def check_settings_used(imitators: Sequence[Imitator], budget: str) -> None:
    """Changed budget settings (--set) with no method that trains would change nothing:
    a one-line error rather than a silent no-op."""
    if split_settings(budget)[1] and not any(i.budgets for i in imitators):
        names = ", ".join(i.name for i in imitators)
        raise FbilError(
            f"--set changes the budget of methods that train (the offline-IL baselines); "
            f"none of {names} does: drop --set or add such a method"
        )


def check_dataset(demos: Demos, dataset: Any) -> None:
    """The dataset must be of the demonstrations' domain (and state size)."""
    want, found = demos.metadata.get("domain"), getattr(dataset, "domain", None)
    if want and found and want != found:
        raise FbilError(
            f"the dataset is of {found}, the demonstrations of {want}; pass --data with a "
            f"{want} dataset"
        )
    width = int(dataset.observation.shape[1])
    demos.validate(width, int(dataset.action.shape[1]), source="demos")


def check_goal_model(demos: Demos, goal_model: Any) -> None:
    """The goal model must be of the demonstrations' domain (and sizes): checked with the
    other methods' inputs, before any of them trains."""
    want = demos.metadata.get("domain")
    if want and want != goal_model.domain:
        raise FbilError(f"the goal model is for {goal_model.domain}, the demonstrations for {want}")
    demos.validate(goal_model.config.obs_dim, goal_model.config.act_dim, source="demos")
