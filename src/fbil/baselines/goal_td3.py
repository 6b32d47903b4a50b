"""GOAL-TD3 (paper 5.2 and App. C.4): a goal-conditioned TD3 pre-trained once per domain
on the unsupervised dataset with hindsight relabeling, then goal-based imitation.

Pre-training (`fbil pretrain-goal`): each minibatch row is a dataset transition
(s, a, s') with a goal g: with probability `her_ratio` (Table 3) a future state of the
same episode, s_{t+1+k} with k ~ Geometric(1 - gamma) - 1 clipped at the episode's end
(k = 0 is s' itself), else a state drawn uniformly from the dataset. The reward is the
sparse r = 1{|s' - g|_2 <= epsilon} (App. C.4), with no termination. The distance is
taken between standardised states by default (`distance`): on raw walker states the nine
velocities (std ~15) drown the fifteen pose coordinates (std ~0.7), and the first walker
run's radius (2 median raw steps, 56.8) counted 59 % of hindsight goals as reached, so
the reward said almost nothing about the goal. Offline TD3 on the
(state, goal) inputs learns pi(s, g); checkpoints are exact, so a run resumes bit for bit.

Imitation (`goal_td3`, family bfm): track the first demonstration's states as goals with
GOALFB's look-ahead rule, goal at step t = s_{min(t + k, l)}: no training, milliseconds.
"""

from __future__ import annotations

import csv
import dataclasses
import json
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
import torch

from fbil.agents.td3 import TD3Config
from fbil.baselines.common import paper_gamma, standardiser, value_bounds
from fbil.baselines.goal_model import GoalModel, GoalModelConfig, goal_agent
from fbil.checkpoint import atomic_write_text, load_state, save_state
from fbil.csvlog import last_wall_seconds, truncate_log
from fbil.errors import FbilError
from fbil.imitation.demos import Demos
from fbil.imitators.base import FitContext, Imitator
from fbil.progress import progress_bar
from fbil.stopping import StopSignals

CHECKPOINT, LOG = "goal_checkpoint.safetensors", "goal_train_log.csv"
LOG_FIELDS = ("step", "critic_loss", "q", "reward_mean", "steps_per_s", "wall_seconds")
LOOKAHEAD = 10  # GOALFB's default look-ahead (`fbil.imitation.api.imitate`)
# Table 3, GOAL-TD3: actor learning rate, critic learning rate, HER ratio.
PAPER_GOAL_TD3 = {
    "walker": (1e-4, 1e-4, 1.0),
    "cheetah": (1e-5, 1e-5, 0.5),
    "quadruped": (1e-4, 1e-4, 0.75),
    "point_mass_maze": (1e-5, 1e-4, 1.0),
}
# Settings a resumed run may change; any other difference is refused.
RESUMABLE = ("steps", "checkpoint_seconds", "log_every")
DISTANCES = ("standardized", "raw")
ARCHS = ("mlp", "two_stream")


@dataclass(frozen=True)
class GoalTD3Config:
    steps: int = 200_000  # maze: 51.8 % at 100 000, 63.8 % at 200 000 (docs/baselines.md)
    hidden: int = 256  # paper: 1024 (the DIAYN networks, App. D.3)
    batch_size: int = 512
    actor_lr: float = 1e-4
    critic_lr: float = 1e-4
    gamma: float = 0.98
    tau: float = 0.01  # target momentum 0.99
    policy_noise: float = 0.2
    noise_clip: float = 0.3
    # Actor updates every policy_delay critic updates on actor_q (TD3Config's meanings):
    # Meta's goal agent updates every step on the min of both critics at a noisy action.
    policy_delay: int = 2
    actor_q: str = "q1"
    target_min: float | None = None  # the TD target's clamp (TD3Config's); for the 0/1
    target_max: float | None = None  # goal reward, [0, 1/(1 - gamma)] bounds every fixed point
    # That clamp, [0, 1/(1 - gamma)], set from the 0/1 reward (`value_bounds`), as the
    # offline-IL baselines' `clamp_values`; False: none (cheetah's offline critics diverge).
    clamp_values: bool = False
    # TD3+BC's alpha on the actor (TD3Config's; the dataset's action is the BC target):
    # keeps pi(s, g) near the data's actions where the critic extrapolates. Diagnostic.
    bc_alpha: float | None = None
    her_ratio: float = 1.0  # goals from the episode's future; the rest: random states
    epsilon: float | None = None  # goal radius; None: epsilon_steps x the median step
    epsilon_steps: float = 1.0  # x the median |s_{t+h} - s_t| in the `distance` metric
    # h of that median (paper: no value for epsilon). Imitation asks for the demo state
    # LOOKAHEAD steps ahead, so h = LOOKAHEAD makes the reward pay for goals at that range
    # about half the time in the data. With h = 1 the maze's radius (0.039 standardised)
    # is one step of velocity noise: a goal 10 steps ahead counted as reached only when
    # both states rest at the same place, and imitation scored -1.6 % (docs/baselines.md).
    epsilon_horizon: int = LOOKAHEAD
    distance: str = "standardized"  # |s' - g| between standardised states, or "raw"
    # The networks (TD3Config's): "mlp", 2 layers on [s, g]; "two_stream", the paper's
    # (App. D.3: s and (s, g), or (s, a) and (s, g), encoded apart, then a 2-layer head).
    arch: str = "mlp"
    # "bf16": hidden layers under bf16 autocast (TD3Config's), "fp32": plain.
    precision: str = "fp32"
    seed: int = 0
    checkpoint_seconds: float = 180.0
    log_every: int = 1000

    def __post_init__(self) -> None:
        if self.steps < 1:
            raise FbilError(f"steps must be >= 1, got {self.steps}")
        if not 0.0 <= self.her_ratio <= 1.0:
            raise FbilError(f"her_ratio must be in [0, 1], got {self.her_ratio}")
        if (self.epsilon is not None and self.epsilon <= 0) or self.epsilon_steps <= 0:
            raise FbilError("the goal radius (epsilon, epsilon_steps) must be > 0")
        if self.epsilon_horizon < 1:
            raise FbilError(f"epsilon_horizon must be >= 1 step, got {self.epsilon_horizon}")
        if self.arch not in ARCHS:
            raise FbilError(f"unknown arch {self.arch!r}; valid: {', '.join(ARCHS)}")
        if self.precision not in ("fp32", "bf16"):
            raise FbilError(f"unknown precision {self.precision!r}; valid: fp32, bf16")
        if self.distance not in DISTANCES:
            raise FbilError(f"unknown distance {self.distance!r}; valid: {', '.join(DISTANCES)}")
        if self.clamp_values and (self.target_min is not None or self.target_max is not None):
            raise FbilError("clamp_values sets target_min/target_max: set one or the other")

    def td3(self) -> TD3Config:
        """The TD3 settings; its one learning rate is the critic's (the trainer sets the
        actor's)."""
        same: tuple[str, ...] = ("hidden", "batch_size", "gamma", "tau", "policy_noise")
        same += ("noise_clip", "policy_delay", "actor_q", "target_min", "target_max", "bc_alpha")
        same += ("precision",)  # the arch goes with the model's config (`goal_agent`)
        settings = {k: getattr(self, k) for k in same}
        if self.clamp_values:
            lo, hi = value_bounds((0.0, 1.0), self.gamma)  # the reward of `goal_reward`
            settings.update(target_min=lo, target_max=hi)
        return TD3Config(lr=self.critic_lr, **settings)


PRESETS = ("cpu", "smoke")


def goal_preset(domain: str, name: str) -> GoalTD3Config:
    """Table 3's settings for `domain` at the preset's size: `cpu` (256 units, 200k
    steps) or `smoke` (seconds, for tests)."""
    if name not in PRESETS:
        raise FbilError(f"unknown preset {name!r}; valid: {', '.join(PRESETS)}")
    actor_lr, critic_lr, her = PAPER_GOAL_TD3.get(domain, (1e-4, 1e-4, 1.0))
    cfg = GoalTD3Config(
        actor_lr=actor_lr, critic_lr=critic_lr, her_ratio=her, gamma=paper_gamma(domain)
    )
    if name == "smoke":
        return dataclasses.replace(cfg, steps=200, hidden=32, batch_size=64, log_every=50)
    return cfg


def median_step(dataset: Any, scale: np.ndarray | None = None, horizon: int = 1) -> float:
    """The median distance |s_{t+h} - s_t| between states h steps apart in one episode of
    the dataset, each coordinate divided by `scale` (none: raw states)."""
    j = dataset.next_index
    start = j - 1  # s_t for every transition; s_{t+h} where the episode lasts that long
    end = start + horizon
    keep = end <= dataset.state_episode_end[start]
    if not keep.any():
        raise FbilError(f"no episode of the dataset lasts {horizon} steps (epsilon_horizon)")
    step = dataset.observation[end[keep]] - dataset.observation[start[keep]]
    return float(np.median(np.linalg.norm(step / (1.0 if scale is None else scale), axis=1)))


def goal_reward(
    next_obs: torch.Tensor, goal: torch.Tensor, epsilon: float, scale: torch.Tensor | None = None
) -> torch.Tensor:
    """r = 1{|(s' - g) / scale|_2 <= epsilon} (App. C.4; scale None: raw states)."""
    diff = next_obs - goal if scale is None else (next_obs - goal) / scale
    return (diff.norm(dim=-1) <= epsilon).float()


class GoalBatch(NamedTuple):
    obs: torch.Tensor
    action: torch.Tensor
    next_obs: torch.Tensor
    goal: torch.Tensor
    reward: torch.Tensor
    discount: torch.Tensor
    row: torch.Tensor  # the row of s' in the dataset's states
    goal_row: torch.Tensor  # the row of g


class HERSampler:
    """Minibatches of dataset transitions with hindsight goals (see the module's doc)."""

    def __init__(
        self,
        dataset: Any,
        cfg: GoalTD3Config,
        epsilon: float,
        gen: torch.Generator,
        scale: torch.Tensor | None = None,
    ) -> None:
        self.scale = scale  # per-coordinate divisor of the goal distance (None: raw)
        self.obs = torch.from_numpy(dataset.observation)
        self.action = torch.from_numpy(dataset.action)
        self.discount = torch.from_numpy(dataset.discount)
        self.next_index = torch.from_numpy(dataset.next_index).long()
        self.episode_end = torch.from_numpy(dataset.state_episode_end).long()
        self.cfg, self.epsilon, self.gen = cfg, epsilon, gen

    def goal_rows(self, rows: torch.Tensor) -> torch.Tensor:
        """Goals for the transitions ending at `rows`: future or random states."""
        n, gen = len(rows), self.gen
        u = torch.rand(n, generator=gen, dtype=torch.float64).clamp_min(1e-12)
        offset = torch.floor(torch.log(u) / np.log(self.cfg.gamma)).long()  # Geom - 1
        future = torch.minimum(rows + offset, self.episode_end[rows])
        anywhere = self.next_index[torch.randint(0, len(self.next_index), (n,), generator=gen)]
        her = torch.rand(n, generator=gen) < self.cfg.her_ratio
        return torch.where(her, future, anywhere)

    def __call__(self) -> GoalBatch:
        pick = torch.randint(0, len(self.next_index), (self.cfg.batch_size,), generator=self.gen)
        j = self.next_index[pick]
        g = self.goal_rows(j)
        goal, next_obs = self.obs[g], self.obs[j]
        reward = goal_reward(next_obs, goal, self.epsilon, self.scale)
        return GoalBatch(
            self.obs[j - 1], self.action[j], next_obs, goal, reward, self.discount[j], j, g
        )


class GoalTD3Trainer:
    """Pre-trains a goal model on a dataset; `fit` checkpoints and resumes exactly."""

    def __init__(self, cfg: GoalTD3Config, dataset: Any) -> None:
        self.cfg, self.dataset = cfg, dataset
        stats = standardiser(dataset.observation, 1e-3)
        scale = stats[1] if cfg.distance == "standardized" else None
        epsilon = cfg.epsilon or cfg.epsilon_steps * median_step(
            dataset, None if scale is None else scale.numpy(), cfg.epsilon_horizon
        )
        obs_dim, act_dim = dataset.observation.shape[1], dataset.action.shape[1]
        self.mcfg = GoalModelConfig(
            dataset.domain,
            obs_dim,
            act_dim,
            cfg.hidden,
            epsilon,
            cfg.gamma,
            cfg.distance,
            cfg.arch,
        )
        self.agent = goal_agent(self.mcfg, cfg.td3(), cfg.seed)
        for group in self.agent.actor_opt.param_groups:
            group["lr"] = cfg.actor_lr
        self.agent.obs_stats = torch.cat([stats, stats], 1)  # state and goal alike
        self.sampler = HERSampler(dataset, cfg, epsilon, self.agent.gen, scale)
        self.step = 0

    def update(self) -> dict[str, float]:
        b = self.sampler()
        inputs, next_inputs = torch.cat([b.obs, b.goal], -1), torch.cat([b.next_obs, b.goal], -1)
        metrics = self.agent.update(inputs, b.action, b.reward, next_inputs, b.discount)
        self.step += 1
        return {**metrics, "reward_mean": float(b.reward.mean())}

    def model(self) -> GoalModel:
        return GoalModel(self.mcfg, self.agent)

    def state(self) -> dict[str, Any]:
        return {
            "agent": self.agent.state(),
            "step": self.step,
            "model_config": dataclasses.asdict(self.mcfg),
            "train_config": dataclasses.asdict(self.cfg),
            "data_digest": self.dataset.digest(),
        }

    def load(self, state: dict[str, Any], where: Path) -> None:
        saved = {k: v for k, v in state["train_config"].items() if k not in RESUMABLE}
        here = {k: v for k, v in dataclasses.asdict(self.cfg).items() if k not in RESUMABLE}
        # A setting added after the checkpoint was saved ran at its default then (e.g.
        # arch and precision, session 57: every earlier run was an fp32 MLP).
        default = {f.name: f.default for f in dataclasses.fields(GoalTD3Config)}
        changed = sorted(k for k in here if saved.get(k, default[k]) != here[k])
        if changed or state["model_config"]["domain"] != self.mcfg.domain:
            what = ", ".join(changed) or "domain"
            raise FbilError(f"{where}: saved with other settings ({what}); use the same preset")
        digest = self.dataset.digest()
        if state.get("data_digest", digest) != digest:  # checkpoints before session 33: none
            raise FbilError(
                f"{where}: trained on data of digest {state['data_digest']}, this dataset's is "
                f"{digest} (another sample); resume on the run's own data"
            )
        self.mcfg = GoalModelConfig(**state["model_config"])  # its epsilon, from its data
        self.sampler.epsilon = self.mcfg.epsilon
        self.agent.load(state["agent"])
        for group in self.agent.actor_opt.param_groups:
            group["lr"] = self.cfg.actor_lr
        self.step = int(state["step"])

    def fit(self, out: str | Path, resume: bool = False, progress: bool = True) -> GoalModel:
        """Train to `cfg.steps`; checkpoint every `checkpoint_seconds` and at the end;
        save the goal model in `out`."""
        out = Path(out)
        self._open_run(out, resume)
        with StopSignals() as stop:
            wall = self._loop(out, progress, last_wall_seconds(out / LOG), stop)
        save_state(out / CHECKPOINT, self.state())
        if stop:
            raise stop.stopped(out, self.step)
        extra = {"steps": self.step, "dataset": str(self.dataset.root), "wall_seconds": wall}
        extra.update(data_digest=self.dataset.digest())
        self.model().save(out, {**extra, "train_config": dataclasses.asdict(self.cfg)})
        return GoalModel.load(out)

    def _open_run(self, out: Path, resume: bool) -> None:
        ckpt = out / CHECKPOINT
        if resume:
            if not ckpt.is_file():
                raise FbilError(f"--resume: no checkpoint in {out} (start without --resume)")
            self.load(load_state(ckpt), ckpt)
            truncate_log(out / LOG, self.step, LOG_FIELDS)
        elif ckpt.exists():
            raise FbilError(f"{out} already holds a goal model: pass --resume or another --out")
        out.mkdir(parents=True, exist_ok=True)

    def _loop(self, out: Path, progress: bool, wall_before: float, stop: StopSignals) -> float:
        log, cfg = out / LOG, self.cfg
        new_log = not log.exists()
        started = last_ckpt = last_log = time.perf_counter()
        at_log = self.step
        bar = progress_bar(
            total=cfg.steps, initial=self.step, disable=not progress, desc="pretrain-goal"
        )
        with open(log, "a", newline="") as fh:
            writer = csv.DictWriter(fh, LOG_FIELDS, extrasaction="ignore")
            if new_log:
                writer.writeheader()
            while self.step < cfg.steps and not stop:
                metrics = self.update()
                now = time.perf_counter()
                if self.step % cfg.log_every == 0 or self.step == cfg.steps:
                    rate = (self.step - at_log) / max(now - last_log, 1e-9)
                    row = {k: round(v, 6) for k, v in metrics.items()}
                    wall = round(wall_before + now - started, 1)
                    writer.writerow(
                        {
                            **row,
                            "step": self.step,
                            "steps_per_s": round(rate, 2),
                            "wall_seconds": wall,
                        }
                    )
                    fh.flush()
                    bar.update(self.step - bar.n)
                    last_log, at_log = now, self.step
                if now - last_ckpt >= cfg.checkpoint_seconds:
                    save_state(out / CHECKPOINT, self.state())
                    last_ckpt = time.perf_counter()
        bar.close()
        return round(wall_before + time.perf_counter() - started, 1)


# -- imitation ---------------------------------------------------------------------------
def goal_row(step: int, length: int, lookahead: int) -> int:
    """The demo state tracked at step t: s_{min(t + k, l)} of states s_0..s_l (`length`
    = l + 1), GOALFB's rule."""
    return min(step + lookahead, length - 1)


class GoalTrackingPolicy:
    """Plays pi(s, g_t) with g_t the demo state `lookahead` steps ahead of step t."""

    suffix = ".json"

    def __init__(self, model: GoalModel, states: np.ndarray, lookahead: int = LOOKAHEAD):
        self.model, self.states, self.lookahead = model, np.asarray(states, np.float32), lookahead
        self._t = 0

    def goal_at(self, step: int) -> np.ndarray:
        return self.states[goal_row(step, len(self.states), self.lookahead)]

    @torch.no_grad()
    def act(self, obs: np.ndarray, step: int | None = None) -> np.ndarray:
        if step is None:
            step, self._t = self._t, self._t + 1
        return self.model.act(obs, self.goal_at(step)[None]).astype(np.float32)

    __call__ = act

    def reset(self) -> None:
        self._t = 0

    def describe(self) -> dict[str, Any]:
        return {
            "lookahead": self.lookahead,
            "goal_steps": len(self.states) - 1,
            "epsilon": self.model.config.epsilon,
            "trajectories_used": 1,
        }

    def save(self, path: str | Path) -> Path:
        """The goals and the goal model's folder (JSON)."""
        body = {
            "method": "goal_td3",
            "goal_model": self.model.directory,
            "lookahead": self.lookahead,
            "goals": self.states.tolist(),
        }
        return atomic_write_text(path, json.dumps(body) + "\n")

    @classmethod
    def load(cls, path: str | Path) -> GoalTrackingPolicy:
        """A file of `save`, with the goal model it names."""
        try:
            body = json.loads(Path(path).read_text())
            goals = np.asarray(body["goals"], np.float32)
            model = GoalModel.load(body["goal_model"])
            lookahead = int(body.get("lookahead", LOOKAHEAD))
        except (OSError, json.JSONDecodeError, KeyError, TypeError, ValueError) as exc:
            raise FbilError(f"{path}: not a goal-tracking policy file ({exc})") from None
        if goals.ndim != 2 or goals.shape[1] != model.config.obs_dim:
            raise FbilError(f"{path}: goals of shape {goals.shape} do not fit the goal model")
        return cls(model, goals, lookahead)


def fit(demos: Demos, context: FitContext) -> GoalTrackingPolicy:
    model: GoalModel = context.goal_model  # its domain and sizes: `Imitator.check`
    # Goal tracking follows one trajectory, the first, as GOALFB.
    return GoalTrackingPolicy(model, demos.trajectories[0].observation)


def _settings(context: FitContext) -> dict[str, Any]:
    # The goal model's folder is the benchmark job's own field (`Job.goal_model`).
    return {"lookahead": LOOKAHEAD}


IMITATOR = Imitator(
    "goal_td3", "bfm", "goal tracking", fit, needs_goal_model=True, settings=_settings
)
