"""What every FB-IL method shares: the model interface, the demonstration batch, the
z-optimiser and the imitation policy.

Demonstration states are weighted so that each trajectory counts equally (paper,
footnote 3: sample a trajectory, then a state in it). Discounted expert features
G_t = sum_{k>=0} gamma^k B(s_{t+k+1}) come from a reverse scan; past a demo's last state
the sum is truncated (the demo says nothing about what follows), which under-weights the
last ~1/(1-gamma) states of each trajectory.
"""

from __future__ import annotations

import json
import math
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

import numpy as np
import torch

from fbil.errors import FbilError
from fbil.imitation.demos import Demos


class FBLike(Protocol):
    """What FB-IL needs of a model (FBModel, or the exact tabular model of the tests)."""

    z_dim: int
    cov_b: torch.Tensor

    def project_z(self, z: Any) -> torch.Tensor: ...

    def backward(self, obs: Any) -> torch.Tensor: ...

    def forward(self, obs: Any, z: Any) -> torch.Tensor: ...  # F(s, z) = F(s, pi_z(s), z)

    def log_prob(self, obs: Any, z: Any, action: Any) -> torch.Tensor: ...

    def act(self, obs: Any, z: Any) -> torch.Tensor: ...


@dataclass
class DemoBatch:
    """All transitions (s_t, a_t, s_{t+1}) of the demonstrations, with their weights."""

    obs: torch.Tensor  # (N, obs_dim)
    next_obs: torch.Tensor  # (N, obs_dim)
    action: torch.Tensor | None  # (N, act_dim)
    weight: torch.Tensor  # (N,), sums to 1, equal total per trajectory
    b_next: torch.Tensor  # (N, d) B(s_{t+1})
    g: torch.Tensor  # (N, d) sum_k gamma^k B(s_{t+k+1}) within the trajectory
    traj: torch.Tensor  # (N,) trajectory index of each row
    step: torch.Tensor  # (N,) t within its trajectory
    gamma: float

    def mean(self, values: torch.Tensor) -> torch.Tensor:
        """rho_e-weighted mean of per-row values."""
        return (self.weight * values).sum()


def discounted_features(b_next: torch.Tensor, gamma: float) -> torch.Tensor:
    """G_t = b_t + gamma G_{t+1} backwards over one trajectory's B(s_{t+1}) rows."""
    g = torch.empty_like(b_next)
    acc = torch.zeros_like(b_next[0])
    for t in range(len(b_next) - 1, -1, -1):
        acc = b_next[t] + gamma * acc
        g[t] = acc
    return g


def prepare(model: FBLike, demos: Demos, gamma: float) -> DemoBatch:
    obs, nxt, act, w, traj, step, g, bn = [], [], [], [], [], [], [], []
    with torch.no_grad():
        for i, t in enumerate(demos.trajectories):
            o = torch.as_tensor(np.asarray(t.observation, np.float32))
            n = len(o) - 1
            b_next = model.backward(o[1:])
            obs.append(o[:-1])
            nxt.append(o[1:])
            if t.action is not None:
                act.append(torch.as_tensor(np.asarray(t.action, np.float32)))
            w.append(torch.full((n,), 1.0 / (n * len(demos))))
            traj.append(torch.full((n,), i))
            step.append(torch.arange(n))
            bn.append(b_next)
            g.append(discounted_features(b_next, gamma))
    return DemoBatch(
        obs=torch.cat(obs),
        next_obs=torch.cat(nxt),
        action=torch.cat(act) if len(act) == len(demos) else None,
        weight=torch.cat(w),
        b_next=torch.cat(bn),
        g=torch.cat(g),
        traj=torch.cat(traj),
        step=torch.cat(step),
        gamma=gamma,
    )


@dataclass(frozen=True)
class OptimiserConfig:
    """Adam on z (projected to the sqrt(d) sphere inside the loss); stops after
    `max_steps`, or once the best loss has not improved by `rel_tol` (relative) for
    `patience` steps."""

    lr: float = 0.05
    max_steps: int = 500
    patience: int = 50
    rel_tol: float = 1e-4


def optimise_z(
    model: FBLike, loss_fn: Any, z0: torch.Tensor, cfg: OptimiserConfig
) -> tuple[torch.Tensor, dict[str, Any]]:
    """Minimise loss_fn(z) over z on the sphere, from z0; the networks stay frozen."""
    z = model.project_z(z0.detach()).clone().requires_grad_(True)
    opt = torch.optim.Adam([z], lr=cfg.lr)
    best, best_z, since, losses = math.inf, z.detach().clone(), 0, []
    for _ in range(cfg.max_steps):
        loss = loss_fn(model.project_z(z))
        if not torch.isfinite(loss):
            raise FbilError("the imitation loss became NaN or inf; check the demonstrations")
        value = float(loss.detach())
        losses.append(value)
        improved = not math.isfinite(best) or value < best - cfg.rel_tol * abs(best)
        if improved:
            best, best_z, since = value, z.detach().clone(), 0
        else:
            since += 1
            if since >= cfg.patience:
                break
        opt.zero_grad()
        loss.backward()
        opt.step()
    info = {"steps": len(losses), "loss_start": losses[0], "loss_best": best}
    return model.project_z(best_z), info


class ImitationPolicy:
    """The result of imitation: a fixed z, or (GOALFB) one z per time step.

    `act(obs, step)` is batched and takes the step index of the episode; without a step
    it keeps its own counter, which `reset()` sets back to 0."""

    def __init__(
        self,
        model: Any,
        method: str,
        z: torch.Tensor,
        seconds: float = 0.0,
        info: dict[str, Any] | None = None,
    ) -> None:
        self.model, self.method, self.seconds = model, method, seconds
        self.z = z.detach()  # (d,) or (T, d) for a schedule
        self.info = dict(info or {})
        self._t = 0

    @property
    def is_schedule(self) -> bool:
        return self.z.ndim == 2

    def z_at(self, step: int) -> torch.Tensor:
        return self.z[min(step, len(self.z) - 1)] if self.is_schedule else self.z

    def reset(self) -> None:
        self._t = 0

    @torch.no_grad()
    def act(self, obs: np.ndarray, step: int | None = None) -> np.ndarray:
        if step is None:
            step, self._t = self._t, self._t + 1
        o = torch.as_tensor(np.asarray(obs, np.float32))
        z = self.z_at(step).reshape(1, -1).expand(len(o), -1)
        return self.model.act(o, z).numpy()

    __call__ = act

    def save(self, path: str | Path) -> Path:
        path = Path(path)
        body = {
            "method": self.method,
            "seconds": self.seconds,
            "z": self.z.tolist(),
            "info": self.info,
        }
        tmp = path.with_name(f".{path.name}.tmp")
        tmp.write_text(json.dumps(body))
        tmp.replace(path)
        return path

    @classmethod
    def load(cls, path: str | Path, model: Any) -> ImitationPolicy:
        try:
            body = json.loads(Path(path).read_text())
            z = torch.tensor(body["z"], dtype=torch.float32)
        except (OSError, json.JSONDecodeError, KeyError, TypeError, ValueError) as exc:
            raise FbilError(f"{path}: not an imitation policy file ({exc})") from None
        if z.shape[-1] != model.z_dim:
            raise FbilError(f"{path}: z has {z.shape[-1]} entries, the model's d is {model.z_dim}")
        return cls(model, body["method"], z, body.get("seconds", 0.0), body.get("info"))


class Timer:
    def __enter__(self) -> Timer:
        self.start = time.perf_counter()
        return self

    def __exit__(self, *exc: object) -> None:
        self.seconds = time.perf_counter() - self.start
