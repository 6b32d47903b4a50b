"""Experts: TD3 trained per task, offline on a relabeled dataset (the maze) or online
(locomotion), saved as safetensors + JSON, and their demonstrations.

`train_expert` checkpoints atomically every few minutes and resumes exactly; a CSV log
records evaluation returns. `make_demos` rolls the expert out deterministically and
writes a demo file (standard or shifted starts, paper App. E.5)."""

from __future__ import annotations

import csv
import dataclasses
import json
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import torch

from fbil import __version__
from fbil.agents.td3 import TD3, TD3Config
from fbil.checkpoint import atomic_write_text, load_state, save_state
from fbil.config import config_from_dict
from fbil.csvlog import last_wall_seconds, truncate_log
from fbil.data import load_dataset
from fbil.envs import BatchedEnv, DomainSpec, get_domain, get_task
from fbil.errors import FbilError
from fbil.imitation.demos import Demos, check_physics, from_episodes
from fbil.progress import progress_bar
from fbil.stopping import StopSignals

CHECKPOINT, EXPERT, LOG = "checkpoint.safetensors", "expert.json", "train_log.csv"
# The best actor seen at the periodic evaluations: offline TD3's return oscillates between
# evaluations on the sparse maze goals, and an expert is only a demonstrator.
BEST = "best.safetensors"
LOG_FIELDS = ("step", "return_mean", "return_std", "critic_loss", "q", "wall_seconds")


class ExpertPolicy:
    """A trained TD3 actor as a batched rollout policy."""

    def __init__(self, agent: TD3, noise: float = 0.0) -> None:
        self.agent, self.noise = agent, noise

    def __call__(self, obs: np.ndarray, step: int) -> np.ndarray:
        return self.agent.act(obs, self.noise)


def evaluate(agent: TD3, domain: str, task: str, episodes: int, seed: int) -> np.ndarray:
    seeds = [seed * 1_000_003 + 50_000 + i for i in range(episodes)]
    return BatchedEnv(domain, task, episodes).rollout(ExpertPolicy(agent), seeds).returns


def train_expert(
    domain: str,
    task: str,
    mode: str,
    out: str | Path,
    data: str | Path | None = None,
    steps: int = 100_000,
    seed: int = 0,
    config: TD3Config | None = None,
    resume: bool = False,
    eval_every: int = 10_000,
    eval_episodes: int = 10,
    checkpoint_seconds: float = 180.0,
    num_envs: int = 1,
    start_steps: int = 10_000,
    progress: bool = True,
    command: str = "",
    init: str | Path | None = None,
) -> dict[str, Any]:
    """Train a TD3 expert; `init` (online only) starts from another expert's networks and
    input statistics (offline-to-online fine-tuning)."""
    spec = _check_arguments(domain, task, mode, data, num_envs, start_steps)
    out = Path(out)
    _check_out(out, resume)
    cfg = config or TD3Config()
    agent = TD3(spec.obs_dim, spec.act_dim, cfg, seed)
    step, learner_state = _restore(agent, cfg, out, resume, init, mode, domain)
    out.mkdir(parents=True, exist_ok=True)
    learner: _OfflineLoop | _OnlineLoop
    if mode == "offline":
        learner = _offline_learner(agent, cfg, data, domain, task, resume)
    else:
        prior = None
        if data is not None:  # RLPD: part of each minibatch from the relabeled dataset
            prior = _prior_sampler(agent, cfg, data, domain, task, stats=not resume and not init)
        learner = _OnlineLoop(
            agent, domain, task, num_envs, start_steps, seed, step, init is not None, prior
        )
    if resume and learner_state:
        learner.load(learner_state)
    run = _Run(out, domain, task, seed, eval_episodes, cfg, agent, learner)
    with StopSignals() as stop:
        step, best = _train_loop(
            run, step, steps, eval_every, checkpoint_seconds, resume, progress, stop
        )
    run.save_checkpoint(step)
    if stop:
        raise stop.stopped(out, step)
    returns = run.evaluate()
    _keep_if_best(out, agent, step, float(returns.mean()), best)  # the last one counts too
    return _write_meta(run, mode, step, data, returns, command)


@dataclasses.dataclass
class _Run:
    """What one expert's training steps share: where it writes, its task, its learner."""

    out: Path
    domain: str
    task: str
    seed: int
    eval_episodes: int
    cfg: TD3Config
    agent: TD3
    learner: _OfflineLoop | _OnlineLoop

    def evaluate(self) -> np.ndarray:
        return evaluate(self.agent, self.domain, self.task, self.eval_episodes, self.seed)

    def save_checkpoint(self, step: int) -> None:
        save_state(self.out / CHECKPOINT, _checkpoint(self.agent, self.learner, step, self.cfg))


def _check_arguments(
    domain: str, task: str, mode: str, data: str | Path | None, num_envs: int, start_steps: int
) -> DomainSpec:
    """The domain's spec, once the arguments are known to make sense."""
    spec = get_domain(domain)
    get_task(domain, task)
    if mode not in ("offline", "online"):
        raise FbilError(f"unknown mode {mode!r}; valid modes: offline, online")
    if num_envs < 1 or start_steps < 0:
        raise FbilError("--num-envs must be >= 1 and --start-steps >= 0")
    if mode == "offline" and data is None:
        raise FbilError("--mode offline needs --data DIR (a dataset to relabel with the task)")
    return spec


def _check_out(out: Path, resume: bool) -> None:
    ckpt = out / CHECKPOINT
    if resume and not ckpt.is_file():
        raise FbilError(f"--resume: no checkpoint in {out} (start without --resume)")
    if not resume and (ckpt.exists() or (out / EXPERT).exists()):
        raise FbilError(f"{out} already holds an expert: pass --resume or choose another --out")


def _restore(
    agent: TD3,
    cfg: TD3Config,
    out: Path,
    resume: bool,
    init: str | Path | None,
    mode: str,
    domain: str,
) -> tuple[int, dict[str, Any]]:
    """Load the checkpoint into `agent` (--resume) or the networks of the `init` expert;
    the step to go on from and the learner's saved state."""
    if resume:
        ckpt = out / CHECKPOINT
        state = load_state(ckpt)
        saved = config_from_dict(TD3Config, state["config"], "TD3 config")
        if saved != cfg:
            raise FbilError(f"{ckpt} was trained with another TD3 config; resume with the same")
        agent.load(state["agent"])
        # Experts saved before 0.1 have no learner state.
        return int(state["step"]), state.get("learner") or {}
    if init is not None:
        if mode != "online":
            raise FbilError("--init fine-tunes an expert online: use it with --mode online")
        _init_from_expert(agent, init, domain)
    return 0, {}


def _offline_learner(
    agent: TD3, cfg: TD3Config, data: str | Path | None, domain: str, task: str, resume: bool
) -> _OfflineLoop:
    dataset = load_dataset(data, domain=domain)  # type: ignore[arg-type]
    if not resume:
        agent.set_obs_stats(dataset.observation)
    return _OfflineLoop(agent, offline_sampler(dataset, task, cfg, agent.gen))


def _prior_sampler(
    agent: TD3, cfg: TD3Config, data: str | Path, domain: str, task: str, stats: bool
) -> Callable[[], tuple[torch.Tensor, ...]]:
    """Online with a dataset: minibatches of round(offline_share x batch) rows of the
    dataset relabeled with the task; its statistics standardise observations (`stats`:
    a fresh run not started from another expert's)."""
    dataset = load_dataset(data, domain=domain)
    if stats:
        agent.set_obs_stats(dataset.observation)
    rows = round(cfg.offline_share * cfg.batch_size)
    if rows < 1:
        raise FbilError(
            f"--data online: offline_share {cfg.offline_share} of batch {cfg.batch_size} "
            "draws no dataset row; raise offline_share or drop --data"
        )
    return offline_sampler(dataset, task, dataclasses.replace(cfg, batch_size=rows), agent.gen)


def _train_loop(
    run: _Run,
    step: int,
    steps: int,
    eval_every: int,
    checkpoint_seconds: float,
    resume: bool,
    progress: bool,
    stop: StopSignals,
) -> tuple[int, float | None]:
    """Learner steps up to `steps` (or a stop signal), evaluating (CSV log, best actor)
    every `eval_every` and checkpointing every `checkpoint_seconds`; the last step and the
    best return."""
    log, best_path = run.out / LOG, run.out / BEST
    if resume:
        truncate_log(log, step, LOG_FIELDS)
    new_log = not log.exists()
    last_ckpt = time.perf_counter()
    started = last_ckpt - last_wall_seconds(log)  # the log's wall time is cumulative
    last: dict[str, float] = {}
    best = load_state(best_path)["return_mean"] if resume and best_path.is_file() else None
    with open(log, "a", newline="") as fh:
        writer = csv.DictWriter(fh, LOG_FIELDS)
        if new_log:
            writer.writeheader()
        bar = progress_bar(
            total=steps, initial=step, disable=not progress, desc=f"expert {run.task}"
        )
        while step < steps and not stop:
            last = run.learner.step() or last
            step += 1
            if step % eval_every == 0 or step == steps:
                returns = run.evaluate()
                writer.writerow(_log_row(step, returns, last, time.perf_counter() - started))
                fh.flush()
                bar.set_postfix(ret=f"{returns.mean():.1f}")
                best = _keep_if_best(run.out, run.agent, step, float(returns.mean()), best)
            if time.perf_counter() - last_ckpt > checkpoint_seconds:
                run.save_checkpoint(step)
                last_ckpt = time.perf_counter()
            bar.update(1)
        bar.close()
    return step, best


def _log_row(
    step: int, returns: np.ndarray, last: dict[str, float], seconds: float
) -> dict[str, float]:
    return {
        "step": step,
        "return_mean": round(float(returns.mean()), 2),
        "return_std": round(float(returns.std()), 2),
        "critic_loss": round(last.get("critic_loss", 0.0), 5),
        "q": round(last.get("q", 0.0), 3),
        "wall_seconds": round(seconds, 1),
    }


def _write_meta(
    run: _Run,
    mode: str,
    step: int,
    data: str | Path | None,
    returns: np.ndarray,
    command: str,
) -> dict[str, Any]:
    """Write expert.json: the run's settings, its last and best evaluated returns and
    every command that trained it."""
    best_state = load_state(run.out / BEST) if (run.out / BEST).is_file() else None
    meta = {
        "domain": run.domain,
        "task": run.task,
        "mode": mode,
        "steps": step,
        "seed": run.seed,
        "config": dataclasses.asdict(run.cfg),
        "data": str(data) if data else None,
        "return_mean": float(returns.mean()),
        "return_std": float(returns.std()),
        "best_step": int(best_state["step"]) if best_state else step,
        "best_return_mean": float(best_state["return_mean"]) if best_state else None,
        "fbil_version": __version__,
        "command": command,
        # Every invocation that trained this expert (a resumed run would otherwise hide
        # how it started, e.g. its --init).
        "commands": [*_previous_commands(run.out / EXPERT), command],
    }
    atomic_write_text(run.out / EXPERT, json.dumps(meta, indent=2) + "\n")
    return meta


def _previous_commands(meta_path: Path) -> list[str]:
    if not meta_path.is_file():
        return []
    meta = json.loads(meta_path.read_text())
    return list(meta.get("commands") or [meta.get("command", "")])


def _init_from_expert(agent: TD3, expert_dir: str | Path, domain: str) -> None:
    """Copy networks, targets and input statistics (not optimiser moments) of the expert
    in `expert_dir` into `agent`."""
    source, meta = load_expert(expert_dir)
    if meta["domain"] != domain:
        raise FbilError(f"--init {expert_dir}: an expert of {meta['domain']}, not {domain}")
    if source.cfg.hidden != agent.cfg.hidden:
        raise FbilError(
            f"--init {expert_dir}: hidden width {source.cfg.hidden} != {agent.cfg.hidden}; "
            f"pass --set hidden={source.cfg.hidden}"
        )
    for name in ("actor", "critics", "actor_target", "critic_targets"):
        getattr(agent, name).load_state_dict(getattr(source, name).state_dict())
    agent.obs_stats = source.obs_stats.clone()


def _keep_if_best(out: Path, agent: TD3, step: int, ret: float, best: float | None) -> float:
    """Save the actor as BEST when `ret` beats the best evaluation so far; the new best."""
    if best is not None and ret <= float(best):
        return float(best)
    save_state(out / BEST, {"agent": agent.state(), "step": step, "return_mean": ret})
    return ret


def _checkpoint(agent: TD3, learner: Any, step: int, cfg: TD3Config) -> dict[str, Any]:
    return {
        "agent": agent.state(),
        "step": step,
        "config": dataclasses.asdict(cfg),
        "learner": learner.state(),
    }


def offline_sampler(
    dataset: Any, task: str, cfg: TD3Config, gen: torch.Generator
) -> Callable[[], tuple[torch.Tensor, ...]]:
    """Minibatches (s, a, R, s_n, discount) of n-step transitions (n = cfg.nstep) from the
    dataset relabeled with `task`: R = sum_i gamma^i r_i along one episode, s_n the state
    n steps later, discount = gamma^(n-1) (TD3's update multiplies by gamma once more)."""
    j = torch.from_numpy(dataset.next_index)
    obs_all = torch.from_numpy(dataset.observation)
    act_all = torch.from_numpy(dataset.action)
    rew_all = torch.from_numpy(dataset.reward(task))
    disc_all = torch.from_numpy(dataset.discount)
    n = cfg.nstep
    if n < 1:
        raise FbilError(f"nstep must be >= 1, got {n}")
    # Start rows p whose next n transitions stay inside one episode.
    p_ok = torch.arange(len(j) - n + 1)
    p_ok = p_ok[j[p_ok + n - 1] == j[p_ok] + n - 1]
    powers = cfg.gamma ** torch.arange(n, dtype=torch.float32)

    def sample() -> tuple[torch.Tensor, ...]:
        p = p_ok[torch.randint(0, len(p_ok), (cfg.batch_size,), generator=gen)]
        rows = p[:, None] + torch.arange(n)  # (B, n) consecutive transitions
        reward = (rew_all[rows] * powers).sum(-1)
        # Bootstrapping weight gamma^(n-1) * prod(discounts); update multiplies by gamma.
        discount = cfg.gamma ** (n - 1) * disc_all[j[rows]].prod(-1)
        return obs_all[j[p] - 1], act_all[j[p]], reward, obs_all[j[p + n - 1]], discount

    return sample


class _OfflineLoop:
    def __init__(self, agent: TD3, sample: Any) -> None:
        self.agent, self.sample = agent, sample

    def step(self) -> dict[str, float]:
        return self.agent.update(*self.sample())

    def state(self) -> dict[str, Any]:
        return {}  # the sampler's generator is the agent's, saved with it

    def load(self, state: dict[str, Any]) -> None:
        pass


class _OnlineLoop:
    """One environment step of `num_envs` environments, then one TD3 update.

    The replay buffer stores rows in order, `num_envs` per step, with each row's time
    within its episode, so n-step returns (cfg.nstep) are read back along one env's
    episode: row k + j * num_envs is that env's j-th next transition."""

    def __init__(
        self,
        agent: TD3,
        domain: str,
        task: str,
        num_envs: int,
        start_steps: int,
        seed: int,
        step: int,
        warm_actor: bool = False,
        prior: Callable[[], tuple[torch.Tensor, ...]] | None = None,
        capacity: int = 1_000_000,
    ) -> None:
        spec = get_domain(domain)
        self.agent, self.start_steps, self.n = agent, start_steps, num_envs
        # A fine-tuned expert fills the first buffer rows with its own noisy actions: uniform
        # random actions would never leave the maze's start room.
        self.warm_actor = warm_actor
        self.prior = prior  # minibatch rows from a relabeled dataset (RLPD), if given
        self.envs = BatchedEnv(domain, task, num_envs).envs
        self.rng = np.random.default_rng(seed + step)
        self.obs = np.zeros((capacity, spec.obs_dim), np.float32)
        self.next_obs = np.zeros((capacity, spec.obs_dim), np.float32)
        self.act = np.zeros((capacity, spec.act_dim), np.float32)
        self.rew = np.zeros(capacity, np.float32)
        self.t = np.full(capacity, -1, np.int64)  # time within the episode
        self.size = self.pos = 0
        self.cap = capacity
        self.env_steps = step * num_envs
        self.episode = 0
        self.seed = seed
        self.current = self._reset_all()

    def _reset_all(self) -> np.ndarray:
        self.episode += 1
        self.ep_t = 0
        return np.stack(
            [
                e.reset(seed=self.seed * 1_000_003 + self.episode * 100 + i)[0]
                for i, e in enumerate(self.envs)
            ]
        )

    def state(self) -> dict[str, Any]:
        # The buffer goes into the checkpoint so that --resume keeps its data; the envs
        # themselves restart from fresh episodes (physics is not checkpointed).
        n = self.size
        return {
            "obs": torch.from_numpy(self.obs[:n]),
            "next_obs": torch.from_numpy(self.next_obs[:n]),
            "act": torch.from_numpy(self.act[:n]),
            "rew": torch.from_numpy(self.rew[:n]),
            "t": torch.from_numpy(self.t[:n]),
            "pos": self.pos,
            "episode": self.episode,
        }

    def load(self, state: dict[str, Any]) -> None:
        n = len(state["rew"])
        for name in ("obs", "next_obs", "act", "rew", "t"):
            getattr(self, name)[:n] = state[name].numpy()
        self.size, self.pos = n, int(state["pos"])
        self.episode = int(state["episode"])
        self.current = self._reset_all()
        # A restarted episode must not chain onto rows written before the kill.
        self.t[self.pos : self.pos + self.n * self.agent.cfg.nstep] = -1

    def step(self) -> dict[str, float]:
        if self.env_steps < self.start_steps and not self.warm_actor:
            a = self.rng.uniform(-1, 1, (self.n, self.act.shape[1])).astype(np.float32)
        else:
            a = self.agent.act(self.current, self.agent.cfg.exploration_noise)
        nxt, rew, done = [], [], False
        for i, env in enumerate(self.envs):
            o, r, _, trunc, _ = env.step(a[i])
            nxt.append(o)
            rew.append(r)
            done = done or trunc
        idx = (self.pos + np.arange(self.n)) % self.cap
        self.obs[idx], self.act[idx], self.rew[idx] = self.current, a, rew
        self.next_obs[idx], self.t[idx] = nxt, self.ep_t
        self.ep_t += 1
        self.pos = int(idx[-1] + 1) % self.cap
        self.size = min(self.size + self.n, self.cap)
        self.env_steps += self.n
        self.current = self._reset_all() if done else np.stack(nxt)
        if self.env_steps < self.start_steps:
            return {}
        if self.prior is None:
            return self.agent.update(*self.sample(self.agent.cfg.batch_size))
        prior = self.prior()
        online = self.sample(self.agent.cfg.batch_size - len(prior[0]))
        both = (torch.cat([a.float(), b.float()]) for a, b in zip(online, prior, strict=True))
        return self.agent.update(*both)

    def sample(self, size: int) -> tuple[torch.Tensor, ...]:
        """`size` n-step transitions (R, s_n, gamma^(n-1)) as `offline_sampler`'s.
        Truncation is not termination: every transition bootstraps."""
        cfg, n = self.agent.cfg, self.agent.cfg.nstep
        span = np.arange(n) * self.n
        k = self.rng.integers(0, self.size, 2 * size + 64)
        rows = (k[:, None] + span) % self.cap
        # Keep starts whose n transitions are one env's consecutive steps of one episode.
        ok = (self.t[rows] == self.t[k][:, None] + np.arange(n)).all(-1)
        rows = rows[ok][:size]
        reward = (self.rew[rows] * cfg.gamma ** np.arange(n)).sum(-1)
        return (
            torch.from_numpy(self.obs[rows[:, 0]]),
            torch.from_numpy(self.act[rows[:, 0]]),
            torch.from_numpy(reward.astype(np.float32)),
            torch.from_numpy(self.next_obs[rows[:, -1]]),
            torch.full((len(rows),), cfg.gamma ** (n - 1)),
        )


def load_expert(directory: str | Path) -> tuple[TD3, dict[str, Any]]:
    """The expert's best evaluated actor (or its last checkpoint) and its expert.json. A
    folder with expert.json and best.safetensors alone (an expert committed without its
    replay buffer) is enough: it makes demos and starts `--init` fine-tuning."""
    directory = Path(directory)
    meta_path, ckpt = directory / EXPERT, directory / CHECKPOINT
    if not meta_path.is_file() or not (ckpt.is_file() or (directory / BEST).is_file()):
        raise FbilError(
            f"no expert in {directory}: expected {EXPERT} and {BEST} or {CHECKPOINT} "
            "(train one with `fbil expert`)"
        )
    meta = json.loads(meta_path.read_text())
    spec = get_domain(meta["domain"])
    cfg = config_from_dict(TD3Config, meta["config"], "TD3 config")
    agent = TD3(spec.obs_dim, spec.act_dim, cfg)
    # Demonstrations come from the best evaluated actor when there is one.
    source = directory / BEST if (directory / BEST).is_file() else ckpt
    agent.load(load_state(source)["agent"])
    meta["actor"] = source.name
    return agent, meta


def shifted_starts(domain: str, agent: TD3, task: str, seeds: list[int]) -> np.ndarray:
    """Physics states to start shifted demonstrations from (paper App. E.5), the domain's
    "shifted" start hook: the maze's top-right room, or step 500 of an expert rollout for
    locomotion."""
    starts = get_domain(domain).start_states("shifted", seeds, task, ExpertPolicy(agent))
    assert starts is not None
    return starts


def make_demos(
    expert_dir: str | Path,
    episodes: int,
    out: str | Path,
    start: str = "standard",
    seed: int = 0,
    physics: str = "all",
) -> Demos:
    """`episodes` expert rollouts as a demo file. `physics` says which demos keep their
    physics states: all (exact reward relabeling, pictures), first (only the one the
    report and `fbil demo` draw: a much smaller file), or none."""
    if start not in ("standard", "shifted"):
        raise FbilError(f"unknown --starts {start!r}; valid: standard, shifted")
    check_physics(physics)  # before the rollouts, not after
    agent, meta = load_expert(expert_dir)
    domain, task = meta["domain"], meta["task"]
    seeds = [seed * 1_000_003 + 200_000 + i for i in range(episodes)]
    starts = shifted_starts(domain, agent, task, seeds) if start == "shifted" else None
    ep = BatchedEnv(domain, task, episodes).rollout(ExpertPolicy(agent), seeds, start_states=starts)
    demos = from_episodes(
        ep,
        {
            "domain": domain,
            "task": task,
            "source": f"TD3 expert {Path(expert_dir).name}",
            "start": start,
            "seed": seed,
        },
    )
    demos = demos.keep_physics(physics)
    demos.save(out)
    return demos
