"""Named training budgets, their scaled forms and single-setting changes, parsed here and
nowhere else.

`auto` (the default) stands for the budget measured for the method on the domain, where
the domain lists one (its `baseline_budgets` hook: walker's TD3-based baselines at
`cpu@5`), else `cpu`; it is resolved before anything trains, and results lines record
the resolved spec.

A budget spec is a name (`cpu`, `smoke`), optionally with a scale, `NAME@SCALE` (`cpu@0.25`,
`cpu@2`), then optionally changed settings, `,PATH=VALUE` each (`cpu,dual.divergence=kl`,
`cpu@0.5,td3.tau=0.01`; what `--set PATH=VALUE` of `fbil imitate/evaluate/benchmark`
appends). SCALE gives the named budget's configuration with every gradient-step count
multiplied by SCALE. The step counts are the fields named `steps` at any depth of the
configuration (a baseline's discriminator, TD3, SAC, dual, BC steps); each is rounded to
the nearest integer and kept at least 1. Everything else (widths, batch sizes, learning
rates, Sinkhorn iterations) is the named budget's. Scaled budgets measure a
score-against-training-time curve without new named budgets (issue #22 item 2,
`scripts/budget_curve.py`). A changed setting replaces one leaf of the (scaled)
configuration, nested ones by dotted path, converted to that setting's type
(`fbil.config.override`): a one-change run of a baseline (a reference's option, another
divergence) without a new named budget; the spec, recorded in every results line, keeps
its results apart from the named budget's.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import Any, TypeVar

from fbil.config import override
from fbil.errors import FbilError

AUTO = "auto"  # the budget measured for the method on the domain, else DEFAULT
DEFAULT = "cpu"
SEPARATOR = "@"
SETTING = ","  # before each changed setting, PATH=VALUE
STEP_FIELD = "steps"  # the name of a gradient-step count in a budget's configuration

T = TypeVar("T")


def budget_help(names: Sequence[str]) -> str:
    """The valid specs, for error messages: 'cpu, smoke (or NAME@SCALE, e.g. cpu@0.5)'."""
    example = names[0] if names else "cpu"
    return f"{', '.join(names)} (or NAME{SEPARATOR}SCALE, e.g. {example}{SEPARATOR}0.5)"


def split_settings(spec: str) -> tuple[str, list[tuple[str, str]]]:
    """'cpu@0.5,dual.lr=3e-4' -> ('cpu@0.5', [('dual.lr', '3e-4')]); a changed setting that is
    not PATH=VALUE is a one-line error."""
    base, *items = spec.split(SETTING)
    settings = []
    for item in items:
        path, eq, value = item.partition("=")
        if not (eq and path.strip() and value.strip()):
            raise FbilError(
                f"bad budget {spec!r}: each setting after {SETTING!r} is PATH=VALUE "
                "(e.g. cpu,dual.divergence=kl; --set dual.divergence=kl)"
            )
        settings.append((path.strip(), value.strip()))
    return base, settings


def with_settings(spec: str, items: Sequence[str] | None) -> str:
    """`spec` with the PATH=VALUE `items` (the CLI's --set) appended: 'cpu,dual.lr=3e-4'."""
    out = SETTING.join([spec, *(items or [])])
    split_settings(out)  # each item well-formed
    return out


def resolve_auto(spec: str, method: str, domain: str | None) -> str:
    """An `auto` spec -> the budget measured for `method` on `domain` (the domain's
    `baseline_budgets` hook), else `cpu`, with the spec's changed settings appended after
    the measured ones: 'auto,td3.tau=0.01' for td3il on walker -> 'cpu@5,td3.tau=0.01'.
    Any other spec is returned as it is."""
    base, settings = split_settings(spec)
    if base != AUTO:
        return spec
    measured = DEFAULT
    if domain is not None:
        from fbil.envs import get_domain

        measured = get_domain(domain).hooks.baseline_budgets.get(method, DEFAULT)
    return with_settings(measured, [f"{path}={value}" for path, value in settings])


def scaled_spec(spec: str, scale: float) -> str:
    """`spec` with all its gradient steps scaled by `scale`: 'cpu,x=1' at 0.5 ->
    'cpu@0.5,x=1' (the bare spec at scale 1; the scale goes on the name, before any changed
    setting). A spec already scaled multiplies, 'cpu@6' at 0.01 -> 'cpu@0.06', and a step
    count set by a changed setting is scaled too, since it would otherwise replace the
    scaled one: 'cpu,sac.steps=200000' at 0.01 -> 'cpu@0.01,sac.steps=2000'."""
    if scale == 1:
        return spec
    base, settings = split_settings(spec)
    name, sep, old = base.partition(SEPARATOR)
    try:
        total = scale * (float(old) if sep else 1.0)
        changed = [
            (p, str(max(1, round(int(v) * scale))) if p.split(".")[-1] == STEP_FIELD else v)
            for p, v in settings
        ]
    except ValueError:
        raise FbilError(f"bad budget {spec!r}: a scale or a step count is not a number") from None
    return SETTING.join([f"{name}{SEPARATOR}{total:g}", *(f"{p}={v}" for p, v in changed)])


def parse_budget(spec: str, names: Sequence[str], owner: str = "") -> tuple[str, float]:
    """`spec` -> (budget name, scale): 'cpu' -> ('cpu', 1.0), 'cpu@0.5' -> ('cpu', 0.5)
    (changed settings, ',PATH=VALUE', are checked for their form only; `Budgets` applies
    them). A name not in `names` or a scale that is not a finite number > 0 is a one-line
    error (`owner`: the imitator whose budget it is, for the message)."""
    base, _ = split_settings(spec)
    name, sep, scale_text = base.partition(SEPARATOR)
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
    """An imitator's named budgets (name -> configuration). Indexing with a spec,
    `budgets['cpu@0.5,dual.lr=3e-4']`, gives the named budget's configuration with its
    steps scaled, then the changed settings applied; iterating gives the names only."""

    def __missing__(self, spec: str) -> Any:
        name, scale = parse_budget(spec, list(self))
        config = scale_steps(self[name], scale)
        for path, value in split_settings(spec)[1]:
            config = override(config, path, value)
        return config
