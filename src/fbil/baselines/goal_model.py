"""A pre-trained goal-conditioned policy (GOAL-TD3's behaviour foundation model) as a model
folder: `goal_td3.safetensors` (actor, twin critics, input statistics) and
`goal_td3.json` (its config and training record), like `FBModel`'s save and load.

The networks are `fbil.agents.td3.TD3`'s on the state and the goal side by side,
pi(s, g) and Q(s, a, g), inputs standardised by the dataset's state statistics."""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal, cast

import numpy as np
import torch
from safetensors import SafetensorError
from safetensors.torch import load_file, save_file

from fbil import __version__
from fbil.agents.td3 import TD3, TD3Config
from fbil.checkpoint import atomic_write_text
from fbil.config import config_from_dict
from fbil.errors import FbilError

WEIGHTS, CONFIG, KIND = "goal_td3.safetensors", "goal_td3.json", "goal_td3"


@dataclass(frozen=True)
class GoalModelConfig:
    domain: str
    obs_dim: int
    act_dim: int
    hidden: int
    epsilon: float  # the goal radius it was trained for: r = 1{|s' - g| <= epsilon}
    gamma: float
    distance: str = "raw"  # the metric of |s' - g|: "standardized" or "raw" (older models)
    arch: str = "mlp"  # TD3Config's: "mlp" or "two_stream" (the paper's; older models: mlp)


def goal_agent(cfg: GoalModelConfig, td3: TD3Config | None = None, seed: int = 0) -> TD3:
    """TD3 networks on (state, goal) inputs: the goal is the input's last obs_dim entries."""
    td3 = td3 or TD3Config(hidden=cfg.hidden, gamma=cfg.gamma)
    arch = cast(Literal["mlp", "two_stream"], cfg.arch)  # TD3Config rejects any other
    td3 = dataclasses.replace(td3, arch=arch, cond_dim=cfg.obs_dim)
    return TD3(2 * cfg.obs_dim, cfg.act_dim, td3, seed)


class GoalModel:
    """pi(s, g) and Q(s, a, g) of a trained goal-conditioned TD3 (inference only)."""

    def __init__(
        self, config: GoalModelConfig, agent: TD3, metadata: dict[str, Any] | None = None
    ) -> None:
        self.config, self.agent = config, agent
        self.metadata = dict(metadata or {})
        self.directory: str | None = None

    @property
    def domain(self) -> str:
        return self.config.domain

    def _inputs(self, obs: Any, goal: Any) -> torch.Tensor:
        o = torch.as_tensor(np.asarray(obs, np.float32))
        g = torch.as_tensor(np.asarray(goal, np.float32)).expand(len(o), -1)
        return torch.cat([o, g], -1)

    def act(self, obs: Any, goal: Any) -> np.ndarray:
        """Actions in [-1, 1] for states (N, d) and goals (N, d) or one goal (1, d)."""
        return self.agent.act(self._inputs(obs, goal).numpy())

    @torch.no_grad()
    def q(self, obs: Any, goal: Any, action: Any) -> torch.Tensor:
        """min(Q1, Q2)(s, a, g), (N,)."""
        act = torch.as_tensor(np.asarray(action, np.float32))
        return self.agent._q(self.agent.critics, self._inputs(obs, goal), act).min(-1).values

    def tensors(self) -> dict[str, torch.Tensor]:
        nets = {"actor": self.agent.actor, "critics": self.agent.critics}
        out = {f"{k}.{n}": t for k, net in nets.items() for n, t in net.state_dict().items()}
        return {**out, "obs_stats": self.agent.obs_stats}

    def _load_tensors(self, state: dict[str, torch.Tensor], path: Path) -> None:
        """Strict: a missing, unexpected or mis-shaped tensor is a one-line error."""
        expected = self.tensors()
        unexpected = sorted(set(state) - set(expected))
        try:
            if unexpected:
                raise RuntimeError(f"unexpected {unexpected[:3]}")
            for name in ("actor", "critics"):
                prefix = f"{name}."
                part = {k[len(prefix) :]: v for k, v in state.items() if k.startswith(prefix)}
                getattr(self.agent, name).load_state_dict(part)
            if state["obs_stats"].shape != expected["obs_stats"].shape:
                raise RuntimeError("mis-shaped obs_stats")
        except (KeyError, RuntimeError) as exc:
            lines = str(exc).strip().splitlines()
            problem = lines[-1].strip() if lines else repr(exc)
            raise FbilError(f"{path}: tensors do not match {CONFIG} ({problem}); retrain") from None
        self.agent.obs_stats = state["obs_stats"].float()

    def save(self, directory: str | Path, extra: dict[str, Any] | None = None) -> Path:
        directory = Path(directory)
        directory.mkdir(parents=True, exist_ok=True)
        tmp = directory / f".{WEIGHTS}.tmp"
        save_file({k: v.detach().contiguous() for k, v in self.tensors().items()}, str(tmp))
        tmp.replace(directory / WEIGHTS)
        self.metadata.update(extra or {})
        body = {"kind": KIND, "model": dataclasses.asdict(self.config), **self.metadata}
        body["fbil_version"] = __version__
        atomic_write_text(directory / CONFIG, json.dumps(body, indent=2) + "\n")
        return directory

    @classmethod
    def load(cls, directory: str | Path) -> GoalModel:
        directory = Path(directory)
        config, body = _read_config(directory)
        model = cls(config, goal_agent(config), body)
        try:
            state = load_file(str(directory / WEIGHTS))
        except (SafetensorError, OSError) as exc:
            raise FbilError(f"{directory / WEIGHTS}: corrupt weights file ({exc})") from None
        model._load_tensors(state, directory / WEIGHTS)
        model.agent.actor.requires_grad_(False)
        model.agent.critics.requires_grad_(False)
        model.directory = str(directory)
        return model


def _read_config(directory: Path) -> tuple[GoalModelConfig, dict[str, Any]]:
    cfg_path = directory / CONFIG
    if not cfg_path.is_file() or not (directory / WEIGHTS).is_file():
        fb = (directory / "config.json").is_file()
        found = " (it holds an FB model)" if fb else ""
        raise FbilError(
            f"no GOAL-TD3 model in {directory}{found}: expected {CONFIG} and {WEIGHTS} "
            "(train one with `fbil pretrain-goal`)"
        )
    try:
        body = json.loads(cfg_path.read_text())
        if body.pop("kind", None) != KIND:
            raise KeyError("kind")
        config = config_from_dict(GoalModelConfig, body.pop("model"), "goal model config")
    except (json.JSONDecodeError, KeyError, TypeError, AttributeError) as exc:
        raise FbilError(f"{cfg_path}: not a valid GOAL-TD3 model config ({exc})") from None
    return config, body
