"""The implied-reward probe: which part of an FB model bounds imitation by reward inference.

A z stands for an implied reward: F(s, a, z)^T z, which pi_z maximises, is the value of
r_z(s') = B(s')^T C^-1 z, with C = E_rho[B B^T] the model's `cov_b` (the successor measure
is F^T B, the value of a reward r is F^T E_rho[B r], and E_rho[B B^T C^-1 z] = z). For
ERFB's z from a task's first demonstration (and z_r, for reference) the probe rolls out
pi_z and measures, in units of r_z's standard deviation over the dataset:

- `gap`: mean r_z over the rollout's states minus mean r_z over the demo's. Below 0, the
  demo earns more of z's own reward than pi_z does: the policy, not the reward, fails.
- `actor_gap` (at the demo's and the rollout's states): max over random actions (and the
  demo's action) of Q(s, a) minus Q(s, pi(s)), in units of Q's spread over the random
  actions. Near 0, the actor takes F's best actions and F's values are the bound; >= 1,
  F knows better actions than the actor takes. `actor_gap_local` searches around pi(s).
- `demo_adv`: Q(s, a_demo) - Q(s, pi(s)) at the demo's states, same units.
- `value`: predicted F(s, pi(s), z)^T z against the discounted r_z the rollout collects.

`python scripts/implied_reward_probe.py MODEL --data DIR --demos DIR --json FILE` runs it;
`fbil report` shows it when an `implied_reward.json` sits next to a domain's results.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch

from fbil.data import Dataset
from fbil.envs import rollout
from fbil.evaluation.sidecar import find_sidecar
from fbil.fb.model import FBModel
from fbil.fb.policy import FBPolicy
from fbil.fb.zero_shot import dataset_backward
from fbil.imitation.core import prepare
from fbil.imitation.demos import Demos
from fbil.imitation.methods.reward import erfb

IMPLIED_FILE = "implied_reward.json"
STARTS = (0, 100, 200, 300, 400, 500)


@dataclass(frozen=True)
class ProbeSettings:
    """How the probe rolls out and searches."""

    episodes: int = 10  # rollouts per z (seeds 10 000, 10 001, ...)
    horizon: int = 300  # steps of the value check after each start
    actions: int = 64  # random (and local) actions of the actor check
    plain: bool = False  # r_z = B^T z instead of B^T C^-1 z


def implied_reward_weights(model: Any, z: torch.Tensor, plain: bool = False) -> torch.Tensor:
    """w with r_z(s') = B(s')^T w the reward whose value F(s, a, z)^T z is: C^-1 z, with
    C = E_rho[B B^T] the model's `cov_b` (z itself with `plain`)."""
    if plain:
        return z
    return torch.linalg.solve(model.cov_b.double(), z.double()).to(z.dtype)


@torch.no_grad()
def value_check(
    model: Any, z: torch.Tensor, w: torch.Tensor, obs: np.ndarray, horizon: int
) -> dict:
    """Predicted F(s_t, pi(s_t), z)^T z against the collected discounted sum of r_z = B^T w
    over `horizon` steps from each start t in STARTS that leaves a whole horizon."""
    n, steps = obs.shape[0], obs.shape[1] - 1
    starts = [t for t in STARTS if t + horizon <= steps]
    disc = model.gamma ** torch.arange(horizon, dtype=w.dtype)
    pred, real = [], []
    for t in starts:
        s = torch.as_tensor(obs[:, t], dtype=w.dtype)
        pred.append(model.q_value(s, z, model.act(s, z)))
        nxt = torch.as_tensor(obs[:, t + 1 : t + 1 + horizon], dtype=w.dtype)
        r = model.backward(nxt.reshape(-1, obs.shape[-1])).reshape(n, horizon, -1) @ w
        real.append((r * disc).sum(1))
    p, r = torch.cat(pred), torch.cat(real)
    return {"predicted": float(p.mean()), "collected": float(r.mean()), "starts": starts}


@torch.no_grad()
def actor_check(
    model: Any, z: torch.Tensor, obs: torch.Tensor, demo_act: torch.Tensor | None, n: int
) -> dict:
    """How much better than the actor's action the best of n uniform random actions (and
    the demo's action), and of n perturbations of the actor's action, are under F."""
    gen = torch.Generator().manual_seed(0)
    rand = torch.rand(len(obs), n, model.config.act_dim, generator=gen) * 2 - 1
    mu = model.act(obs, z)
    local = (mu[:, None] + 0.2 * torch.randn(rand.shape, generator=gen)).clamp(-1, 1)
    cand = torch.cat([rand, local] + ([] if demo_act is None else [demo_act[:, None]]), 1)
    k = cand.shape[1]
    flat = cand.reshape(-1, cand.shape[-1])
    q = model.q_value(obs.repeat_interleave(k, 0), z, flat).reshape(-1, k)
    q_pi = model.q_value(obs, z, mu)
    scale = q[:, :n].std(1).clamp_min(1e-6)
    best_global = torch.cat([q[:, :n], q[:, 2 * n :]], 1).max(1).values
    out = {
        "saturated": float((mu.abs() > 0.99).float().mean()),
        "actor_gap": float(((best_global - q_pi) / scale).mean()),
        "actor_gap_local": float(((q[:, n : 2 * n].max(1).values - q_pi) / scale).mean()),
    }
    if demo_act is not None:
        out["demo_adv"] = float(((q[:, -1] - q_pi) / scale).mean())
    return out


@torch.no_grad()
def probe_z(
    model: FBModel,
    z: torch.Tensor,
    task: str,
    b_data: torch.Tensor,
    batch: Any,
    cfg: ProbeSettings,
    domain: str,
) -> dict:
    """One z of one task: its rollout's return, r_z over rollout / demo / data (`gap`), F's
    value check and the actor checks. `batch`: the demo's `prepare`d batch."""
    w = implied_reward_weights(model, z, cfg.plain)
    seeds = [10_000 + i for i in range(cfg.episodes)]
    episodes = rollout(domain, task, FBPolicy(model, z), seeds)
    obs = episodes.observation
    visited = torch.as_tensor(obs[:, 1:].reshape(-1, obs.shape[-1]), dtype=torch.float32)
    r_data = b_data @ w
    r_roll, r_demo = float((model.backward(visited) @ w).mean()), float((batch.b_next @ w).mean())
    std = float(r_data.std())
    return {
        "return_mean": float(np.mean(episodes.returns)),
        "r_z_rollout": r_roll,
        "r_z_demo": r_demo,
        "r_z_data_mean": float(r_data.mean()),
        "r_z_data_std": std,
        # nan where r_z does not vary over the data (z has no implied reward to compare)
        "gap": (r_roll - r_demo) / std if std > 0 else float("nan"),
        "value": value_check(model, z, w, obs, cfg.horizon),
        "at_demo": actor_check(model, z, batch.obs, batch.action, cfg.actions),
        "at_rollout": actor_check(model, z, visited[::10], None, cfg.actions),
    }


def probe_model(
    model: FBModel, data: Dataset, demos_dir: str | Path, tasks: Sequence[str], cfg: ProbeSettings
) -> dict[str, Any]:
    """The probe over tasks: per task, the first demo's return and ERFB's and z_r's rows."""
    b = dataset_backward(model, data)
    table: dict[str, Any] = {"domain": data.domain, "data": str(data.root), "demos": str(demos_dir)}
    table["settings"] = asdict(cfg)
    table["tasks"] = {}
    for task in tasks:
        reward = torch.from_numpy(data.reward(task)).reshape(-1, 1).float()
        demos = Demos.load(Path(demos_dir) / f"{task}.npz").select([0])
        batch = prepare(model, demos, gamma=model.gamma)
        zs = {"ERFB": erfb(model, batch)[0], "z_r": model.project_z((reward * b).mean(0))}
        demo_reward = demos.trajectories[0].reward  # None for demos recorded without rewards
        ret = float("nan") if demo_reward is None else float(demo_reward.sum())
        row: dict[str, Any] = {"demo_return": ret}
        for name, z in zs.items():
            row[name] = probe_z(model, z, task, b, batch, cfg, data.domain)
        table["tasks"][task] = row
    return table


def find_implied(files: Sequence[str | Path], domain: str) -> dict[str, Any] | None:
    """The implied_reward.json next to one of the results files, if it is of `domain`."""
    return find_sidecar(files, IMPLIED_FILE, domain, "rerun scripts/implied_reward_probe.py")


def reading(row: dict[str, Any]) -> str:
    """What bounds ERFB on one task, by the probe's reading rules."""
    er = row["ERFB"]
    if er["return_mean"] >= 0.5 * row["demo_return"]:
        return "– (ERFB reaches half the demo's return)"
    if er["gap"] > -0.5:
        return "the implied reward (B)"
    gaps = (er["at_demo"]["actor_gap"], er["at_rollout"]["actor_gap"])
    if max(gaps) >= 1.0:
        return "the actor"
    return "F" if max(gaps) <= 0.5 else "F and the actor"


def implied_section(table: dict[str, Any]) -> list[str]:
    """The report's part on the probe: one row per task, with its reading."""
    lines = [
        "## Reward inference: what a demo's z pays, and what its policy collects",
        "",
        f"`scripts/implied_reward_probe.py` on `{table.get('model', 'the model')}` "
        "(`fbil.evaluation.implied`): ERFB's z from the task's first demonstration stands for "
        "the reward r_z = B^T C^-1 z. *gap*: r_z over pi_z's rollout minus r_z over the "
        "demo, in standard deviations of r_z over the data (below 0: the demo earns more of "
        "z's own reward than pi_z does). *actor gap*: how far F's best action (random search) "
        "beats the actor's, at the demo's / the rollout's states. *demo adv*: F's value of the "
        "demo's action minus the actor's, at the demo's states.",
        "",
        "| task | ERFB return (demo) | gap | actor gap | demo adv | z_r gap | bound |",
        "|---|---|---|---|---|---|---|",
    ]
    for task, row in table["tasks"].items():
        er, zr = row["ERFB"], row["z_r"]
        lines.append(
            f"| {task} | {er['return_mean']:.1f} ({row['demo_return']:.1f}) | {er['gap']:.2f} | "
            f"{er['at_demo']['actor_gap']:.2f} / {er['at_rollout']['actor_gap']:.2f} | "
            f"{er['at_demo'].get('demo_adv', float('nan')):.2f} | {zr['gap']:.2f} | "
            f"{reading(row)} |"
        )
    return [*lines, ""]
