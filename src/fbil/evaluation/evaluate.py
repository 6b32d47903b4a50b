"""The paper's protocol for one task: imitate from K demonstrations, roll the imitation
policies out from the standard initial distribution, score return / expert return.

Methods are imitators of any family, by name (`fbil.imitators`). All methods of one call
share one batched rollout (one environment per method and episode; FB-IL policies of one
model act in one call, each environment with its own z), so adding methods costs
policy-call rows, not Python loops."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from fbil.envs.rollout import BatchedEnv, Episodes
from fbil.errors import FbilError
from fbil.fb.model import model_domain
from fbil.imitation.core import OptimiserConfig
from fbil.imitation.demos import Demos
from fbil.imitators import (
    FitContext,
    Fitted,
    Policy,
    family_of,
    get_imitator,
    principle_of,
    resolve,
)

EVAL_SEED_OFFSET = 500_000  # evaluation episodes never reuse the demos' seeds (200_000 + i)


def resolve_methods(spec: str | Sequence[str]) -> list[str]:
    """'all' (the paper's eight FB-IL methods), a family, a comma list or a list ->
    validated method names."""
    return resolve(spec).names


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
    """Several imitation policies played side by side: rows [i*E, (i+1)*E) use policy i.
    Neighbouring policies with the same `together_key` (FB-IL: one model) act in one call
    of their class's `act_together`; any other policy acts on its own rows."""

    def __init__(self, policies: Sequence[Policy], episodes: int) -> None:
        self.episodes = episodes
        self.runs: list[list[Policy]] = []
        for p in policies:
            key = getattr(p, "together_key", None)
            last = self.runs[-1][-1] if self.runs else None
            if key is not None and key == getattr(last, "together_key", None):
                self.runs[-1].append(p)
            else:
                self.runs.append([p])

    def __call__(self, obs: np.ndarray, step: int) -> np.ndarray:
        parts, row = [], 0
        for run in self.runs:
            rows = obs[row : row + len(run) * self.episodes]
            together = getattr(type(run[0]), "act_together", None)
            if together is not None:
                parts.append(together(run, self.episodes, rows, step))
            else:
                parts.append(run[0].act(rows, step))
            row += len(rows)
        return parts[0] if len(parts) == 1 else np.concatenate(parts)


def rollout_policies(
    policies: Sequence[Policy],
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
    family: str = "fb-il"
    physics: np.ndarray | None = None  # its physics states (T+1, physics_dim)
    # The fitted policy's own summary (`Policy.describe`): z for FB-IL; a trained
    # learner's last update, with `q_diverged` where its rewards bound its values.
    fit: dict[str, Any] = field(default_factory=dict)

    def as_dict(self) -> dict[str, Any]:
        return {
            "family": self.family,
            "principle": self.principle,
            "return_mean": self.return_mean,
            "return_std": self.return_std,
            "score": self.score,
            "seconds": self.seconds,
        }


def demos_task(demos: Demos, model: Any) -> tuple[str, str]:
    """(domain, task) of the demos, checked against the model's domain (if a model)."""
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


def fit_all(
    names: Sequence[str], demos: Demos, context: FitContext, skip_unfit: bool
) -> tuple[list[Fitted], dict[str, str]]:
    """Every method fitted to `demos`, after checking all of them (a mistake stops the
    call before any work). With `skip_unfit`, a method that needs actions the demos lack
    is skipped with its reason instead of refused."""
    skipped: dict[str, str] = {}
    chosen = []
    for name in names:
        imitator = get_imitator(name)
        if skip_unfit and imitator.needs_actions and not demos.has_actions:
            skipped[name] = "needs expert actions; the demonstrations have none"
            continue
        imitator.check(demos, context)
        chosen.append(imitator)
    return [i.fit(demos, context) for i in chosen], skipped


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
    dataset: Any = None,
    budget: str = "auto",
    skip_unfit: bool = False,
    goal_model: Any = None,
    checkpoint: Any = None,
) -> dict[str, Any]:
    """Imitate draw `draw` of K demos with each method, evaluate, score against the expert
    (`expert`: its mean return from the standard start; default: the demos' own record).
    `model`: the FB model (FB-IL methods), `dataset`: the unsupervised dataset and
    `budget` (methods that train), `goal_model`: a pre-trained goal model (goal_td3).
    Methods the demos cannot serve (no actions) are skipped when named by a group ('all',
    a family) or with `skip_unfit`, else refused. `checkpoint`: the fit's
    `fbil.checkpoint.FitCheckpoint`, for one method that trains (`fbil benchmark`'s jobs)."""
    selection = resolve(methods)
    if checkpoint is not None and len(selection.names) != 1:
        raise FbilError("a fit checkpoint serves one method's fit; name one method")
    if episodes < 1:  # before any method trains (a baseline's fit takes minutes)
        raise FbilError(f"--episodes must be >= 1, got {episodes}")
    domain, task = demos_task(demos, model)
    expert = expert_return(demos) if expert is None else float(expert)
    if expert <= 0:
        raise FbilError(f"the expert's mean return is {expert}; scores need a positive one")
    chosen = demo_draw(demos, k, draw)
    context = FitContext(
        model,
        dataset,
        budget,
        seed,
        optimiser=optimiser,
        goal_model=goal_model,
        checkpoint=checkpoint,
    )
    fitted, skipped = fit_all(selection.names, chosen, context, skip_unfit or selection.group)
    results = _rolled_out(fitted, domain, task, episodes, seed, expert)
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


def _rolled_out(
    fitted: Sequence[Any], domain: str, task: str, episodes: int, seed: int, expert: float
) -> dict[str, MethodResult]:
    """Each fitted policy's result over `episodes` episodes, all in one batched rollout."""
    if not fitted:
        return {}
    results: dict[str, MethodResult] = {}
    ep = rollout_policies([f.policy for f in fitted], domain, task, episodes, seed)
    for i, f in enumerate(fitted):
        r = ep.returns[i * episodes : (i + 1) * episodes]
        results[f.name] = MethodResult(
            f.name,
            principle_of(f.name),
            float(r.mean()),
            float(r.std()),
            float(r.mean() / expert),
            f.seconds,
            [float(x) for x in r],
            ep.observation[i * episodes],
            family_of(f.name),
            ep.physics[i * episodes],
            f.policy.describe(),
        )
    return results
