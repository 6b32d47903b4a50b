"""`fbil collect`: reward-free episodes written one by one, resumable after a kill.

Each lockstep batch of episodes is written file by file (atomically) as soon as it ends,
then the explorer's checkpoint and the manifest; a kill loses at most the batch in flight.
`resume=True` keeps every complete file, removes temporary leftovers, restores the
explorer and refills its replay from the newest episodes on disk.
"""

from __future__ import annotations

import dataclasses
import platform
import time
from pathlib import Path
from typing import Any

import numpy as np
import torch

from fbil import __version__
from fbil.artifacts import machine
from fbil.checkpoint import load_state, save_state
from fbil.data.coverage import coverage_tracker
from fbil.data.rnd import RNDConfig, RNDPopulation
from fbil.data.storage import (
    episode_arrays,
    list_episodes,
    load_episode,
    read_manifest,
    write_episode,
    write_manifest,
)
from fbil.envs import DOMAINS, BatchedEnv, RandomPolicy, get_domain
from fbil.errors import FbilError
from fbil.progress import progress_bar

EXPLORERS = ("rnd", "random")
STARTS = ("standard", "uniform")
CHECKPOINT = "explorer.safetensors"


def _episode_seed(seed: int, index: int) -> int:
    return seed * 1_000_003 + index


def _check_existing(
    out: Path,
    resume: bool,
    domain: str,
    explorer: str,
    seed: int,
    rnd_config: dict[str, Any] | None,
    starts: str = "standard",
) -> int:
    """Number of complete episodes already in `out` (0 for a fresh collection)."""
    buf = out / "buffer"
    existing = list_episodes(out) if buf.is_dir() else []
    if not resume:
        if existing:
            raise FbilError(
                f"{out} already holds {len(existing)} episodes: pass --resume to continue, "
                "or choose another --out"
            )
        return 0
    manifest = read_manifest(out)
    if manifest is None:
        raise FbilError(f"nothing to resume in {out}: no manifest.json (start without --resume)")
    for key, value in (
        ("domain", domain),
        ("explorer", explorer),
        ("seed", seed),
        ("rnd_config", rnd_config),
        ("starts", starts),
    ):
        if manifest.get(key, "standard" if key == "starts" else None) != value:
            raise FbilError(
                f"{out} was collected with {key}={manifest.get(key)!r}, not {value!r}: "
                "resume with the same settings or choose another --out"
            )
    for tmp in buf.glob(".*.tmp"):
        tmp.unlink()  # an episode or checkpoint that was being written when killed
    for f in existing:
        load_episode(f.path, ("observation",))  # a damaged file stops here, by name
    indices = [f.index for f in existing]
    if indices != list(range(len(indices))):
        raise FbilError(f"{out}: episode indices are not 0..{len(indices) - 1}; cannot resume")
    return len(existing)


def collect(
    domain: str,
    explorer: str,
    episodes: int,
    out: str | Path,
    seed: int = 0,
    resume: bool = False,
    rnd_config: RNDConfig | None = None,
    threads: int | None = None,
    progress: bool = True,
    command: str = "",
    starts: str = "standard",
) -> dict[str, Any]:
    """Collect `episodes` reward-free episodes. `starts` names one of the domain's start
    variants: "uniform" (the maze) starts each episode at a uniformly random free position
    of the whole maze instead of the top-left room: with the cpu-sized budget (1 M steps,
    not ExORL's 10 M), RND from the standard start leaves the bottom rooms' interiors
    unvisited."""
    _check_request(domain, explorer, episodes, starts)
    if threads is not None:
        torch.set_num_threads(threads)
    out = Path(out)
    cfg = rnd_config or RNDConfig()
    rnd_dict = dataclasses.asdict(cfg) if explorer == "rnd" else None
    done = _check_existing(out, resume, domain, explorer, seed, rnd_dict, starts)
    manifest: dict[str, Any] = (read_manifest(out) if resume else None) or {
        "domain": domain,
        "explorer": explorer,
        "seed": seed,
        "fbil_version": __version__,
        "command": command,
        "layout": "ExORL: buffer/<timestamp>_<idx>_<len>.npz, arrays of length T+1",
        "reward": "none (reward-free; relabel with a task)",
        "rnd_config": rnd_dict,
        "starts": starts,
        "machine": platform.machine(),
        "cpu": machine(),
        "wall_seconds": 0.0,
    }
    manifest["episodes_requested"] = episodes
    write_manifest(out, manifest)
    run = _Run(domain, out, seed, starts, cfg, manifest)
    run.start(explorer, done)
    bar = progress_bar(
        total=episodes, initial=done, disable=not progress, desc=f"collect {domain}", unit="ep"
    )
    while done < episodes:
        n = min(cfg.num_envs, episodes - done)
        bar.set_postfix(run.batch(done, n))
        bar.update(n)
        done += n
    bar.close()
    return manifest


def _check_request(domain: str, explorer: str, episodes: int, starts: str) -> None:
    spec = get_domain(domain)
    if starts not in STARTS:
        raise FbilError(f"unknown --starts {starts!r}; valid: {', '.join(STARTS)}")
    if starts != "standard" and starts not in spec.hooks.starts:
        defined = ", ".join(d.name for d in DOMAINS.values() if starts in d.hooks.starts)
        raise FbilError(f"--starts {starts} is defined for {defined} only")
    if explorer not in EXPLORERS:
        raise FbilError(f"unknown explorer {explorer!r}; valid explorers: {', '.join(EXPLORERS)}")
    if episodes < 1:
        raise FbilError(f"--episodes must be at least 1, got {episodes}")


class _Run:
    """One collection in progress: the explorer, its environments, the running coverage."""

    def __init__(
        self,
        domain: str,
        out: Path,
        seed: int,
        starts: str,
        cfg: RNDConfig,
        manifest: dict[str, Any],
    ) -> None:
        self.spec, self.out, self.seed, self.starts = get_domain(domain), out, seed, starts
        self.cfg, self.manifest = cfg, manifest
        self.envs: dict[int, BatchedEnv] = {}
        self.tracker = coverage_tracker(domain)
        self.agent: RNDPopulation | None = None
        self.policy: Any = None
        self.started, self.steps = time.perf_counter(), 0
        self.wall_before = float(manifest.get("wall_seconds", 0.0))

    def start(self, explorer: str, done: int) -> None:
        """The explorer (restored when resuming) and the coverage of the last episodes."""
        if explorer == "rnd":
            self.agent = RNDPopulation(self.spec.obs_dim, self.spec.act_dim, self.cfg, self.seed)
            ckpt = self.out / CHECKPOINT
            if done and ckpt.is_file():
                self.agent.load(load_state(ckpt))
            _refill(self.agent, self.out, done)
            self.policy = self.agent
        else:
            self.policy = RandomPolicy(self.spec.act_dim, seed=_episode_seed(self.seed, done))
        if done:
            for f in list_episodes(self.out)[-200:]:
                self.tracker.update(load_episode(f.path, ("observation",))["observation"])
        self.started = time.perf_counter()

    def batch(self, done: int, n: int) -> dict[str, str]:
        """Roll out and write episodes done..done+n-1; returns the progress bar's postfix."""
        spec, agent = self.spec, self.agent
        batch = self.envs.setdefault(n, BatchedEnv(spec.name, None, n))
        seeds = [_episode_seed(self.seed, i) for i in range(done, done + n)]
        start_states = spec.start_states(self.starts, seeds)
        ep = batch.rollout(self.policy, seeds, start_states=start_states)
        if agent is not None:
            agent.end_episodes(ep.observation, ep.action)
        for i in range(n):
            write_episode(
                self.out,
                done + i,
                episode_arrays(ep.observation[i], ep.action[i], ep.reward[i], ep.physics[i]),
            )
        self.steps += n * spec.episode_length
        if agent is not None:
            save_state(self.out / CHECKPOINT, agent.state())
        self.tracker.update(ep.observation)
        elapsed = time.perf_counter() - self.started
        self.manifest.update(
            episodes=done + n,
            transitions=(done + n) * spec.episode_length,
            wall_seconds=round(self.wall_before + elapsed, 1),
        )
        write_manifest(self.out, self.manifest)
        postfix = {"steps/s": f"{self.steps / elapsed:.0f}", "coverage": self.tracker.summary()}
        if agent is not None:
            postfix["intrinsic"] = f"{agent.last_intrinsic:.3g}"
        return postfix


def _refill(population: RNDPopulation, out: Path, done: int) -> None:
    """Refill each explorer's replay from the newest episodes it collected (episodes are
    dealt to explorers in blocks of num_envs / agents within each batch)."""
    if not done:
        return
    cfg = population.cfg
    per_agent = cfg.num_envs // cfg.agents
    keep = max(1, cfg.replay_capacity // 1000) * cfg.agents
    for f in list_episodes(out)[-keep:]:
        agent = population.agents[(f.index % cfg.num_envs) // per_agent]
        ep = load_episode(f.path, ("observation", "action"))
        obs, act = ep["observation"][None], ep["action"][None, 1:]
        agent.replay.add_steps(obs, act, range(act.shape[1]))
        agent.obs_norm.update(torch.from_numpy(np.asarray(ep["observation"][1:])))
