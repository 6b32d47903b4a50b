"""Named training budgets and their scaled forms, parsed here and nowhere else.

A budget spec is a name (`cpu`, `smoke`) or a name with a scale, `NAME@SCALE` (`cpu@0.25`,
`cpu@2`): the named budget's configuration with every gradient-step count multiplied by
SCALE. The step counts are the fields named `steps` at any depth of the configuration (a
baseline's discriminator, TD3, SAC, dual, BC steps); each is rounded to the nearest integer
and kept at least 1. Everything else (widths, batch sizes, learning rates, Sinkhorn
iterations) is the named budget's. Scaled budgets measure a score-against-training-time
curve without new named budgets (issue #22 item 2, `scripts/budget_curve.py`).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import Any, TypeVar

from fbil.errors import FbilError

SEPARATOR = "@"
STEP_FIELD = "steps"  # the name of a gradient-step count in a budget's configuration

T = TypeVar("T")


def budget_help(names: Sequence[str]) -> str:
    """The valid specs, for error messages: 'cpu, smoke (or NAME@SCALE, e.g. cpu@0.5)'."""
    example = names[0] if names else "cpu"
    return f"{', '.join(names)} (or NAME{SEPARATOR}SCALE, e.g. {example}{SEPARATOR}0.5)"


def parse_budget(spec: str, names: Sequence[str], owner: str = "") -> tuple[str, float]:
    """`spec` -> (budget name, scale): 'cpu' -> ('cpu', 1.0), 'cpu@0.5' -> ('cpu', 0.5).
    A name not in `names` or a scale that is not a finite number > 0 is a one-line error
    (`owner`: the imitator whose budget it is, for the message)."""
    name, sep, scale_text = spec.partition(SEPARATOR)
    where = f" for {owner}" if owner else ""
    if name not in names:
        raise FbilError(f"unknown budget {spec!r}{where}; valid: {budget_help(names)}")
    if not sep:
        return name, 1.0
    try:
        scale = float(scale_text)
    except ValueError:
        scale = math.nan
    if not (math.isfinite(scale) and scale > 0):
        raise FbilError(
            f"bad budget {spec!r}{where}: the scale after {SEPARATOR!r} must be a number > 0 "
            f"(e.g. {name}{SEPARATOR}0.5)"
        )
    return name, scale


def scale_steps(config: T, scale: float) -> T:
    """`config` (a dataclass) with every `steps` field, nested ones included, multiplied
    by `scale` (rounded, at least 1); the same object when `scale` is 1."""
    if scale == 1.0:
        return config
    changes: dict[str, Any] = {}
    for f in dataclasses.fields(config):  # type: ignore[arg-type]
        value = getattr(config, f.name)
        if dataclasses.is_dataclass(value) and not isinstance(value, type):
            changes[f.name] = scale_steps(value, scale)
        elif f.name == STEP_FIELD and isinstance(value, int):
            changes[f.name] = max(1, round(value * scale))
    return dataclasses.replace(config, **changes)  # type: ignore[type-var]


class Budgets(dict[str, Any]):
    """An imitator's named budgets (name -> configuration). Indexing with a scaled spec,
    `budgets['cpu@0.5']`, gives the named budget's configuration with its steps scaled;
    iterating gives the names only."""

    def __missing__(self, spec: str) -> Any:
        name, scale = parse_budget(spec, list(self))
        return scale_steps(self[name], scale)
