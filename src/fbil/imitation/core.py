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
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

import numpy as np
import torch

from fbil.errors import FbilError
from fbil.imitation.demos import Demos


class FBLike(Protocol):
    """What FB-IL needs of a model (FBModel, or the exact tabular model of the tests)."""

    cov_b: torch.Tensor

    @property
    def z_dim(self) -> int: ...

    @property
    def gamma(self) -> float: ...  # the discount of its successor measures

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
    rows: torch.Tensor | None = None  # for a minibatch: its rows in the full batch

    def mean(self, values: torch.Tensor) -> torch.Tensor:
        """rho_e-weighted mean of per-row values."""
        return (self.weight * values).sum()

    def sample(self, n: int, generator: torch.Generator) -> DemoBatch:
        """n rows drawn with probability rho_e (then equally weighted): a minibatch whose
        losses are unbiased estimates of the full ones."""
        rows = torch.multinomial(self.weight, n, replacement=True, generator=generator)
        return DemoBatch(
            obs=self.obs[rows],
            next_obs=self.next_obs[rows],
            action=None if self.action is None else self.action[rows],
            weight=torch.full((n,), 1.0 / n, dtype=self.weight.dtype),
            b_next=self.b_next[rows],
            g=self.g[rows],
            traj=self.traj[rows],
            step=self.step[rows],
            gamma=self.gamma,
            rows=rows,
        )


def discounted_features(b_next: torch.Tensor, gamma: float) -> torch.Tensor:
    """G_t = b_t + gamma G_{t+1} backwards over one trajectory's B(s_{t+1}) rows (a linear
    recursion, run by scipy's IIR filter in C)."""
    from scipy.signal import lfilter

    x = b_next.detach().double().numpy()[::-1]
    g = lfilter([1.0], [1.0, -gamma], x, axis=0)[::-1].copy()
    return torch.from_numpy(g).to(b_next.dtype)


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
    """Adam on z (projected to the sqrt(d) sphere inside the loss), for a fixed budget of
    `steps` minibatches of `batch_size` demonstration rows drawn from rho_e
    (None: the full batch every step, deterministic). The budget is the stopping rule:
    `benchmarks/time_to_policy.py --curve` shows imitation quality against it.
    precision "bf16" runs the frozen networks under bf16 autocast (z, its gradient and the
    loss stay fp32): half the time on AVX-512 CPUs; float64 models are never cast."""

    lr: float = 0.05
    # Measured: more steps did not imitate better (docs/imitation.md, "Quality against the
    # optimisation budget").
    steps: int = 50
    batch_size: int | None = 128
    seed: int = 0
    precision: str = "bf16"

    def __post_init__(self) -> None:
        if self.precision not in ("fp32", "bf16"):
            raise FbilError(f"unknown precision {self.precision!r}; valid: fp32, bf16")


def optimise_z(
    model: FBLike, loss_fn: Any, batch: DemoBatch, z0: torch.Tensor, cfg: OptimiserConfig
) -> tuple[torch.Tensor, dict[str, Any]]:
    """Minimise loss_fn(z, batch) over z on the sphere from z0; the networks stay frozen."""
    z = model.project_z(z0.detach()).clone().requires_grad_(True)
    opt = torch.optim.Adam([z], lr=cfg.lr)
    gen = torch.Generator().manual_seed(cfg.seed)
    losses = []
    amp = torch.autocast("cpu", torch.bfloat16, enabled=cfg.precision == "bf16")
    for _ in range(cfg.steps):
        part = batch if cfg.batch_size is None else batch.sample(cfg.batch_size, gen)
        with amp:
            loss = loss_fn(model.project_z(z), part).float()
        if not torch.isfinite(loss):
            raise FbilError("the imitation loss became NaN or inf; check the demonstrations")
        losses.append(float(loss.detach()))
        opt.zero_grad()
        loss.backward()
        opt.step()
    info = {
        "steps": cfg.steps,
        "loss_first": losses[0] if losses else math.nan,
        "loss_last": losses[-1] if losses else math.nan,
    }
    return model.project_z(z.detach()), info


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

    suffix = ".json"  # the file type of `save`

    def describe(self) -> dict[str, Any]:
        """z's norm and first entries (of its first step, for a schedule), and the numbers
        of the method's info."""
        z = self.z
        return {
            "z_norm": float(z.norm(dim=-1).mean()),
            "z_head": [round(float(v), 4) for v in (z[0] if self.is_schedule else z)[:4]],
            "schedule_steps": int(z.shape[0]) if self.is_schedule else None,
            **{k: v for k, v in self.info.items() if isinstance(v, int | float)},
        }

    @property
    def together_key(self) -> tuple[str, int]:
        """Policies with equal keys can act in one call (`act_together`): one model."""
        return ("fb", id(self.model))

    @staticmethod
    @torch.no_grad()
    def act_together(
        policies: Sequence[ImitationPolicy], episodes: int, obs: np.ndarray, step: int
    ) -> np.ndarray:
        """Rows [i*episodes, (i+1)*episodes) of `obs` played by policies[i], in one call of
        their shared model (each row with its policy's z)."""
        z = torch.cat([p.z_at(step).reshape(1, -1).expand(episodes, -1) for p in policies])
        return policies[0].model.act(torch.as_tensor(obs), z).numpy()

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


LossFn = Callable[[FBLike, DemoBatch, torch.Tensor], torch.Tensor]


def gradient_method(loss: LossFn) -> Callable[..., tuple[torch.Tensor, dict[str, Any]]]:
    """An FB-IL method that minimises `loss(model, batch, z)` from the warm start z0."""

    def infer(
        model: FBLike,
        batch: DemoBatch,
        z0: torch.Tensor,
        optimiser: OptimiserConfig,
        **_: Any,
    ) -> tuple[torch.Tensor, dict[str, Any]]:
        return optimise_z(model, lambda z, part: loss(model, part, z), batch, z0, optimiser)

    infer.__doc__ = loss.__doc__
    return infer
