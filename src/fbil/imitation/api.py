"""`imitate(model, demos, method)`: an imitation policy from demonstrations, in seconds."""

from __future__ import annotations

from typing import Any

from fbil.errors import FbilError
from fbil.imitation.core import FBLike, ImitationPolicy, OptimiserConfig, Timer, prepare
from fbil.imitation.demos import Demos
from fbil.imitation.methods import METHODS, reward


def imitate(
    model: FBLike,
    demos: Demos,
    method: str,
    gamma: float | None = None,
    optimiser: OptimiserConfig | None = None,
    lookahead: int = 10,
) -> ImitationPolicy:
    """Imitate `demos` with one FB-IL method (see `fbil.imitation.METHODS`)."""
    if method not in METHODS:
        raise FbilError(f"unknown method {method!r}; valid methods: {', '.join(METHODS)}, all")
    spec = METHODS[method]
    cfg = getattr(model, "config", None)
    demos.validate(getattr(cfg, "obs_dim", None), getattr(cfg, "act_dim", None))
    if spec.needs_actions and not demos.has_actions:
        raise FbilError(
            f"{method} needs expert actions, and these demonstrations have none; "
            "use an action-free method (e.g. erfb, goalfb)"
        )
    gamma = model.gamma if gamma is None else gamma
    optimiser = optimiser or OptimiserConfig()
    with Timer() as timer:
        batch = prepare(model, demos, gamma)
        options: dict[str, Any] = {"optimiser": optimiser, "lookahead": lookahead}
        if spec.gradient:
            options["z0"], _ = reward.erfb(model, batch)  # warm start (paper App. E.2)
        z, info = spec.infer(model, batch, **options)
    return ImitationPolicy(model, method, z, seconds=timer.seconds, info=info)
