"""The nine FB-IL methods as imitators: `imitate(model, demos, method)` behind `fit`."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any

from fbil.imitation.api import imitate
from fbil.imitation.core import OptimiserConfig
from fbil.imitation.demos import Demos
from fbil.imitation.methods import METHODS
from fbil.imitators.base import FitContext, Imitator, Policy


def _fit(method: str) -> Callable[[Demos, FitContext], Policy]:
    def fit(demos: Demos, context: FitContext) -> Policy:
        return imitate(context.model, demos, method, optimiser=context.optimiser)

    return fit


def _settings(context: FitContext) -> dict[str, Any]:
    return {"optimiser": dataclasses.asdict(context.optimiser or OptimiserConfig())}


FB_IMITATORS = [
    Imitator(
        name,
        "fb-il",
        method.principle,
        _fit(name),
        needs_actions=method.needs_actions,
        needs_model=True,
        settings=_settings,
    )
    for name, method in METHODS.items()
]
