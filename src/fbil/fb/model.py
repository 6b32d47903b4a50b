"""The forward-backward model: B(s), F(s, a, z) with two heads, the policy mu(s, z), and
Cov B, with inference verbs that each return z on the sphere of radius sqrt(d).

Loaded models are in eval mode with frozen parameters, so a caller can still
differentiate with respect to z (what the FB-IL gradient methods do) without ever
touching the networks.
"""

from __future__ import annotations

import dataclasses
import itertools
import json
import math
from pathlib import Path
from typing import Any, Literal

import numpy as np
import torch
from safetensors import SafetensorError
from safetensors.torch import load_file, save_file
from torch import nn

from fbil import __version__
from fbil.checkpoint import atomic_write_text
from fbil.config import config_from_dict
from fbil.errors import FbilError
from fbil.fb.config import FBModelConfig

Tensorish = torch.Tensor | np.ndarray
Heads = Literal["mean", "min", "both", "first"]
WEIGHTS, CONFIG = "model.safetensors", "config.json"


def _as_tensor(x: Tensorish) -> torch.Tensor:
    return torch.as_tensor(np.asarray(x, dtype=np.float32) if isinstance(x, np.ndarray) else x)


def embedding(inp: int, hidden: int, out: int) -> nn.Sequential:
    """First layer layer-normalised with tanh (standardises raw states and actions)."""
    return nn.Sequential(
        nn.Linear(inp, hidden), nn.LayerNorm(hidden), nn.Tanh(), nn.Linear(hidden, out), nn.ReLU()
    )


class ObsNorm(nn.Module):
    """(obs - mean) / std with the training data's statistics, saved with the model."""

    obs_stats: torch.Tensor

    def __init__(self, obs_dim: int) -> None:
        super().__init__()
        self.register_buffer("obs_stats", torch.stack([torch.zeros(obs_dim), torch.ones(obs_dim)]))

    def forward(self, obs: torch.Tensor) -> torch.Tensor:
        return (obs - self.obs_stats[0]) / self.obs_stats[1]


def obs_norm(cfg: FBModelConfig) -> nn.Module:
    return ObsNorm(cfg.obs_dim) if cfg.normalize_obs else nn.Identity()


class TwinHead(nn.Module):
    """k MLP heads over one input, computed as batched matmuls (one pass for all heads)."""

    def __init__(self, inp: int, hidden: int, out: int, layers: int, k: int = 2) -> None:
        super().__init__()
        sizes = [inp] + [hidden] * layers + [out]
        self.k = k
        self.weights = nn.ParameterList()
        self.biases = nn.ParameterList()
        for fan_in, fan_out in itertools.pairwise(sizes):
            bound = 1 / math.sqrt(fan_in)  # nn.Linear's default initialisation
            self.weights.append(
                nn.Parameter(torch.empty(k, fan_in, fan_out).uniform_(-bound, bound))
            )
            self.biases.append(nn.Parameter(torch.empty(k, 1, fan_out).uniform_(-bound, bound)))

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        """x: (N, inp), one input for all heads, or (k, N, inp), one per head -> (k, N, out)."""
        h = x if x.dim() == 3 else x.unsqueeze(0).expand(self.k, *x.shape)
        last = len(self.weights) - 1
        for i, (w, b) in enumerate(zip(self.weights, self.biases, strict=True)):
            h = torch.baddbmm(b, h, w)
            if i < last:
                h = torch.relu(h)
        return h


@torch.no_grad()
def orthogonal_init(module: nn.Module) -> None:
    """Orthogonal weights (gain 1) and zero biases for every linear layer under `module`,
    twin heads included (each head's matrix on its own); layer norms keep ones and zeros."""
    for m in module.modules():
        if isinstance(m, nn.Linear):
            nn.init.orthogonal_(m.weight)
            nn.init.zeros_(m.bias)
        elif isinstance(m, TwinHead):
            for w, b in zip(m.weights, m.biases, strict=True):
                for head in w:  # (fan_in, fan_out): orthogonal like Linear's (out, in) weight
                    nn.init.orthogonal_(head.T)
                nn.init.zeros_(b)


class BackwardNet(nn.Module):
    def __init__(self, cfg: FBModelConfig) -> None:
        super().__init__()
        h = cfg.b_hidden
        self.obs_norm = obs_norm(cfg)
        self.net = nn.Sequential(
            nn.Linear(cfg.obs_dim, h),
            nn.LayerNorm(h),
            nn.Tanh(),
            nn.Linear(h, h),
            nn.ReLU(),
            nn.Linear(h, cfg.z_dim),
        )
        self.norm = cfg.b_norm
        self.z_dim = cfg.z_dim
        if cfg.b_norm == "batchnorm":
            self.bn = nn.BatchNorm1d(cfg.z_dim, affine=False, momentum=0.01)

    def forward(self, obs: torch.Tensor) -> torch.Tensor:
        b = self.net(self.obs_norm(obs))
        if self.norm == "l2":
            return math.sqrt(self.z_dim) * nn.functional.normalize(b, dim=-1)
        if self.norm == "batchnorm":
            return self.bn(b)
        return b


class ForwardNet(nn.Module):
    """F's two heads over shared (s, a) and (s, z) embeddings, or (`f_heads="independent"`)
    each head with embeddings of its own, so no parameter is common to the two."""

    def __init__(self, cfg: FBModelConfig) -> None:
        super().__init__()
        h, e = cfg.f_hidden, cfg.f_embed
        self.obs_norm = obs_norm(cfg)
        self.independent = cfg.f_heads == "independent"
        if self.independent:
            self.sa_heads = nn.ModuleList(
                embedding(cfg.obs_dim + cfg.act_dim, h, e) for _ in range(2)
            )
            self.sz_heads = nn.ModuleList(
                embedding(cfg.obs_dim + cfg.z_dim, h, e) for _ in range(2)
            )
        else:
            self.sa = embedding(cfg.obs_dim + cfg.act_dim, h, e)
            self.sz = embedding(cfg.obs_dim + cfg.z_dim, h, e)
        self.heads = TwinHead(2 * e, h, cfg.z_dim, layers=2 if cfg.extra_layer else 1)

    def forward(self, obs: torch.Tensor, z: torch.Tensor, action: torch.Tensor) -> torch.Tensor:
        """(2, N, d): both heads."""
        obs = self.obs_norm(obs)
        sa, sz = torch.cat([obs, action], -1), torch.cat([obs, z], -1)
        if self.independent:
            pairs = zip(self.sa_heads, self.sz_heads, strict=True)
            return self.heads(torch.stack([torch.cat([f(sa), g(sz)], -1) for f, g in pairs]))
        return self.heads(torch.cat([self.sa(sa), self.sz(sz)], -1))


class Actor(nn.Module):
    def __init__(self, cfg: FBModelConfig) -> None:
        super().__init__()
        h, e = cfg.f_hidden, cfg.f_embed
        self.obs_norm = obs_norm(cfg)
        self.s = embedding(cfg.obs_dim, h, e)
        self.sz = embedding(cfg.obs_dim + cfg.z_dim, h, e)
        layers: list[nn.Module] = [nn.Linear(2 * e, h), nn.ReLU()]
        if cfg.extra_layer:
            layers += [nn.Linear(h, h), nn.ReLU()]
        self.head = nn.Sequential(*layers, nn.Linear(h, cfg.act_dim), nn.Tanh())

    def forward(self, obs: torch.Tensor, z: torch.Tensor) -> torch.Tensor:
        obs = self.obs_norm(obs)
        return self.head(torch.cat([self.s(obs), self.sz(torch.cat([obs, z], -1))], -1))


def model_domain(metadata: dict[str, Any] | None) -> str | None:
    """The training data's domain as recorded in a model's metadata (None if unrecorded)."""
    meta = metadata or {}
    domain = meta.get("domain") or (meta.get("dataset_manifest") or {}).get("domain")
    return str(domain) if domain else None


class FBModel(nn.Module):
    """F, B, mu and Cov B of one environment."""

    def __init__(self, config: FBModelConfig, metadata: dict[str, Any] | None = None) -> None:
        super().__init__()
        self.config = config
        self.metadata: dict[str, Any] = dict(metadata or {})
        self.backward_net = BackwardNet(config)
        self.forward_net = ForwardNet(config)
        self.actor = Actor(config)
        self.cov_b: torch.Tensor
        self.register_buffer("cov_b", torch.eye(config.z_dim))

    @property
    def z_dim(self) -> int:
        return self.config.z_dim

    @property
    def gamma(self) -> float:
        """The discount the model was trained with: its successor measures use it, and so
        must imitation. Read from the saved training config; a model without one is refused
        rather than given a default that silently mis-scales every demo's features."""
        train = self.metadata.get("train_config") or {}
        if "gamma" not in train:
            raise FbilError(
                "this FB model records no training discount (train_config.gamma); "
                "pass gamma= explicitly or re-save it with `fbil pretrain`"
            )
        return float(train["gamma"])

    @property
    def domain(self) -> str | None:
        """The domain of the data the model was trained on, when its metadata says."""
        return model_domain(self.metadata)

    # -- z -----------------------------------------------------------------------------
    def project_z(self, z: Tensorish) -> torch.Tensor:
        """Onto the sphere of radius sqrt(d), where every z of the model lives."""
        return math.sqrt(self.z_dim) * nn.functional.normalize(_as_tensor(z), dim=-1)

    def sample_z(self, n: int, generator: torch.Generator | None = None) -> torch.Tensor:
        return self.project_z(torch.randn(n, self.z_dim, generator=generator))

    # -- networks ------------------------------------------------------------------------
    def backward(self, obs: Tensorish) -> torch.Tensor:
        """B(s), (N, d)."""
        return self.backward_net(_as_tensor(obs))

    def forward(
        self, obs: Tensorish, z: Tensorish, action: Tensorish | None = None, heads: Heads = "mean"
    ) -> torch.Tensor:
        """F(s, a, z); with no action, F(s, mu(s, z), z). `heads`: mean or min of the two
        heads (N, d), the first head (N, d), or both (2, N, d)."""
        obs, z = _as_tensor(obs), self.project_z(z)
        if z.ndim == 1:  # one z for every state, as in `act`
            z = z.expand(obs.shape[0], -1)
        act = self.actor(obs, z) if action is None else _as_tensor(action)
        f = self.forward_net(obs, z, act)
        if heads == "both":
            return f
        if heads == "first":
            return f[0]
        return f.mean(0) if heads == "mean" else f.min(0).values

    def act(self, obs: Tensorish, z: Tensorish) -> torch.Tensor:
        """Deterministic action mu(s, z) in [-1, 1]."""
        obs = _as_tensor(obs)
        z = self.project_z(z)
        if z.ndim == 1:
            z = z.expand(obs.shape[0], -1)
        return self.actor(obs, z)

    def log_prob(self, obs: Tensorish, z: Tensorish, action: Tensorish) -> torch.Tensor:
        """ln pi_z(a | s) up to a constant: a Gaussian of std `policy_std` around mu(s, z)
        (the policy-smoothing noise the actor was trained with)."""
        mu = self.act(obs, z)
        return -((mu - _as_tensor(action)) ** 2).sum(-1) / (2 * self.policy_std**2)

    policy_std: float = 0.2

    def q_value(self, obs: Tensorish, z: Tensorish, action: Tensorish) -> torch.Tensor:
        """F(s, a, z)^T z (mean of the heads): the value of a under the reward whose z is z."""
        z = self.project_z(z)
        return (self.forward(obs, z, action) * z).sum(-1)

    # -- inference verbs: each returns a projected z ------------------------------------
    def reward_inference(self, next_obs: Tensorish, rewards: Tensorish) -> torch.Tensor:
        """z_r = E[r(s') B(s')] over the given (next state, reward) samples."""
        with torch.no_grad():
            b = self.backward(next_obs)
            r = _as_tensor(rewards).reshape(-1, 1)
            return self.project_z((r * b).mean(0))

    def goal_inference(self, obs: Tensorish) -> torch.Tensor:
        """z = B(s) of one goal state (or one z per row for a batch)."""
        with torch.no_grad():
            return self.project_z(self.backward(obs))

    # -- persistence ---------------------------------------------------------------------
    def save(self, directory: str | Path, extra: dict[str, Any] | None = None) -> Path:
        directory = Path(directory)
        directory.mkdir(parents=True, exist_ok=True)
        tmp = directory / f".{WEIGHTS}.tmp"
        state = {k: v.detach().contiguous() for k, v in self.state_dict().items()}
        save_file(state, str(tmp))
        tmp.replace(directory / WEIGHTS)
        meta = {**self.metadata, **(extra or {})}
        body = {"model": dataclasses.asdict(self.config), "fbil_version": __version__, **meta}
        atomic_write_text(directory / CONFIG, json.dumps(body, indent=2) + "\n")
        return directory

    @classmethod
    def load(cls, directory: str | Path) -> FBModel:
        directory = Path(directory)
        cfg_path, w_path = directory / CONFIG, directory / WEIGHTS
        if not cfg_path.is_file() or not w_path.is_file():
            raise FbilError(
                f"no FB model in {directory}: expected {CONFIG} and {WEIGHTS} "
                "(train one with `fbil pretrain`)"
            )
        try:
            body = json.loads(cfg_path.read_text())
            config = config_from_dict(FBModelConfig, body.pop("model"), "FB model config")
        except (json.JSONDecodeError, KeyError, TypeError) as exc:
            raise FbilError(f"{cfg_path}: not a valid FB model config ({exc})") from None
        model = cls(config, metadata=body)
        try:
            state = load_file(str(w_path))
        except (SafetensorError, OSError) as exc:
            raise FbilError(f"{w_path}: corrupt weights file ({exc})") from None
        expected = model.state_dict()
        missing = sorted(set(expected) - set(state))
        unexpected = sorted(set(state) - set(expected))
        shapes = [k for k in expected if k in state and state[k].shape != expected[k].shape]
        if missing or unexpected or shapes:
            problem = (
                f"missing {missing[:3]}"
                if missing
                else f"unexpected {unexpected[:3]}"
                if unexpected
                else f"mis-shaped {shapes[:3]}"
            )
            raise FbilError(f"{w_path}: tensors do not match {CONFIG} ({problem}); retrain")
        model.load_state_dict(state)
        return model.frozen()

    @torch.no_grad()
    def set_obs_stats(self, observations: np.ndarray) -> None:
        """Set the input standardisation (normalize_obs models) from a dataset's states."""
        obs = torch.as_tensor(observations, dtype=torch.float64)
        stats = torch.stack([obs.mean(0), obs.std(0).clamp_min(1e-3)]).float()
        for module in self.modules():
            if isinstance(module, ObsNorm):
                module.obs_stats.copy_(stats.to(module.obs_stats.device))

    def frozen(self) -> FBModel:
        """Eval mode, no parameter gradients (z can still require grad)."""
        self.eval()
        self.requires_grad_(False)
        return self
