"""The paper's protocol for one task: imitate from K demonstrations, roll the imitation
policies out from the standard initial distribution, score return / expert return.

All methods of one call share one batched rollout (one environment per method and
episode; each environment plays its own z), so adding methods costs policy-call rows,
not Python loops."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import torch

from fbil.envs.rollout import BatchedEnv, Episodes
from fbil.errors import FbilError
from fbil.fb.model import model_domain
from fbil.imitation.api import imitate
from fbil.imitation.core import ImitationPolicy, OptimiserConfig
from fbil.imitation.demos import Demos
from fbil.imitation.methods import MAIN_METHODS, METHODS

EVAL_SEED_OFFSET = 500_000  # evaluation episodes never reuse the demos' seeds (200_000 + i)


def resolve_methods(spec: str | Sequence[str]) -> list[str]:
    """'all' (the paper's eight), a comma list, or a list -> validated method names."""
    names = spec.split(",") if isinstance(spec, str) else list(spec)
    names = [n.strip().lower() for n in names if n.strip()]
    if names == ["all"]:
        return list(MAIN_METHODS)
    unknown = [n for n in names if n not in METHODS]
    if unknown or not names:
        raise FbilError(
            f"unknown method {', '.join(unknown) or '(none)'}; valid: {', '.join(METHODS)}, all"
        )
    return names


def expert_return(demos: Demos) -> float:
    """The expert's mean return: the demo file's record, else the demos' own rewards."""
    if "return_mean" in demos.metadata:
        return float(demos.metadata["return_mean"])
    rewards = [t.reward for t in demos.trajectories if t.reward is not None]
    if len(rewards) < len(demos):
        raise FbilError(
            "the demonstrations carry no expert return (metadata 'return_mean') and no "
            "rewards; record them with `fbil demos`, or add the expert's mean return"
        )
    return float(np.mean([float(np.sum(r)) for r in rewards]))


def demo_draw(demos: Demos, k: int, draw: int) -> Demos:
    """The `draw`-th disjoint group of K demonstrations (wrapping around the file)."""
    n = len(demos)
    if not 1 <= k <= n:
        raise FbilError(f"--k must be in [1, {n}] for this file, got {k}")
    return demos.select([(draw * k + i) % n for i in range(k)])


class MultiPolicy:
    """Several imitation policies played side by side: rows [i*E, (i+1)*E) use policy i."""

    def __init__(self, policies: Sequence[ImitationPolicy], episodes: int) -> None:
        self.policies, self.episodes = list(policies), episodes
        self.model = policies[0].model

    @torch.no_grad()
    def __call__(self, obs: np.ndarray, step: int) -> np.ndarray:
        z = torch.cat(
            [p.z_at(step).reshape(1, -1).expand(self.episodes, -1) for p in self.policies]
        )
        return self.model.act(torch.as_tensor(obs), z).numpy()


def rollout_policies(
    policies: Sequence[ImitationPolicy],
    domain: str,
    task: str,
    episodes: int,
    seed: int = 0,
) -> Episodes:
    """`episodes` evaluation episodes of every policy, in one batched rollout."""
    if episodes < 1:
        raise FbilError(f"--episodes must be >= 1, got {episodes}")
    seeds = [EVAL_SEED_OFFSET + seed * 10_000 + i for i in range(episodes)] * len(policies)
    env = BatchedEnv(domain, task, len(seeds))
    return env.rollout(MultiPolicy(policies, episodes), seeds)


@dataclass(frozen=True)
class MethodResult:
    method: str
    principle: str
    return_mean: float
    return_std: float
    score: float
    seconds: float
    returns: list[float]
    trajectory: np.ndarray  # observations of the first evaluation episode (T+1, obs_dim)

    def as_dict(self) -> dict[str, Any]:
        return {
            "principle": self.principle,
            "return_mean": self.return_mean,
            "return_std": self.return_std,
            "score": self.score,
            "seconds": self.seconds,
        }


def demos_task(demos: Demos, model: Any) -> tuple[str, str]:
    """(domain, task) of the demos, checked against the model's domain."""
    domain, task = demos.metadata.get("domain"), demos.metadata.get("task")
    if not domain or not task:
        raise FbilError(
            "the demonstrations do not say their domain and task (metadata 'domain', "
            "'task'); evaluation needs the task's reward"
        )
    trained_on = model_domain(getattr(model, "metadata", None))
    if trained_on and trained_on != domain:
        raise FbilError(f"the model is for {trained_on}, the demonstrations for {domain}")
    return str(domain), str(task)


def evaluate(
    model: Any,
    demos: Demos,
    methods: str | Sequence[str] = "all",
    k: int = 1,
    draw: int = 0,
    episodes: int = 10,
    seed: int = 0,
    optimiser: OptimiserConfig | None = None,
    expert: float | None = None,
) -> dict[str, Any]:
    """Imitate draw `draw` of K demos with each method, evaluate, score against the expert
    (`expert`: its mean return from the standard start; default: the demos' own record)."""
    names = resolve_methods(methods)
    domain, task = demos_task(demos, model)
    expert = expert_return(demos) if expert is None else float(expert)
    if expert <= 0:
        raise FbilError(f"the expert's mean return is {expert}; scores need a positive one")
    chosen = demo_draw(demos, k, draw)
    skipped: dict[str, str] = {}
    policies: list[ImitationPolicy] = []
    for name in names:
        if METHODS[name].needs_actions and not chosen.has_actions:
            skipped[name] = "needs expert actions; the demonstrations have none"
            continue
        policies.append(imitate(model, chosen, name, optimiser=optimiser))
    results: dict[str, MethodResult] = {}
    if policies:
        ep = rollout_policies(policies, domain, task, episodes, seed)
        for i, p in enumerate(policies):
            r = ep.returns[i * episodes : (i + 1) * episodes]
            results[p.method] = MethodResult(
                p.method,
                METHODS[p.method].principle,
                float(r.mean()),
                float(r.std()),
                float(r.mean() / expert),
                p.seconds,
                [float(x) for x in r],
                ep.observation[i * episodes],
            )
    return {
        "domain": domain,
        "task": task,
        "k": k,
        "draw": draw,
        "episodes": episodes,
        "expert_return": expert,
        "results": results,
        "skipped": skipped,
    }
