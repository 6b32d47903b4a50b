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
from tqdm.auto import tqdm

from fbil import __version__
from fbil.checkpoint import load_state, save_state
from fbil.data.coverage import CoverageTracker
from fbil.data.rnd import RNDConfig, RNDPopulation
from fbil.data.storage import (
    episode_arrays,
    list_episodes,
    load_episode,
    read_manifest,
    write_episode,
    write_manifest,
)
from fbil.envs import BatchedEnv, RandomPolicy, get_domain
from fbil.envs.maze import random_free_positions
from fbil.errors import FbilError

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
    """Collect `episodes` reward-free episodes. `starts="uniform"` (maze only) starts each
    episode at a uniformly random free position of the whole maze instead of the top-left
    room: with the cpu-sized budget (1 M steps, not ExORL's 10 M), RND from the standard
    start leaves the bottom rooms' interiors unvisited."""
    spec = get_domain(domain)
    if starts not in STARTS:
        raise FbilError(f"unknown --starts {starts!r}; valid: {', '.join(STARTS)}")
    if starts == "uniform" and domain != "point_mass_maze":
        raise FbilError("--starts uniform is defined for point_mass_maze only")
    if explorer not in EXPLORERS:
        raise FbilError(f"unknown explorer {explorer!r}; valid explorers: {', '.join(EXPLORERS)}")
    if episodes < 1:
        raise FbilError(f"--episodes must be at least 1, got {episodes}")
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
        "wall_seconds": 0.0,
    }
    manifest["episodes_requested"] = episodes
    write_manifest(out, manifest)

    policy: Any
    if explorer == "rnd":
        agent = RNDPopulation(spec.obs_dim, spec.act_dim, cfg, seed)
        ckpt = out / CHECKPOINT
        if done and ckpt.is_file():
            agent.load(load_state(ckpt))
        _refill(agent, out, done)
        policy = agent
    else:
        agent = None
        policy = RandomPolicy(spec.act_dim, seed=_episode_seed(seed, done))

    tracker = CoverageTracker(domain)
    if done:
        for f in list_episodes(out)[-200:]:
            tracker.update(load_episode(f.path, ("observation",))["observation"])
    envs: dict[int, BatchedEnv] = {}
    bar = tqdm(
        total=episodes, initial=done, disable=not progress, desc=f"collect {domain}", unit="ep"
    )
    started, steps = time.perf_counter(), 0
    wall_before = float(manifest.get("wall_seconds", 0.0))
    while done < episodes:
        n = min(cfg.num_envs, episodes - done)
        batch = envs.setdefault(n, BatchedEnv(domain, None, n))
        seeds = [_episode_seed(seed, i) for i in range(done, done + n)]
        start_states = None
        if starts == "uniform":
            rng = np.random.default_rng(seeds[0])
            start_states = np.concatenate([random_free_positions(rng, n), np.zeros((n, 2))], 1)
        ep = batch.rollout(policy, seeds, start_states=start_states)
        if agent is not None:
            agent.end_episodes(ep.observation, ep.action)
        for i in range(n):
            write_episode(
                out,
                done + i,
                episode_arrays(ep.observation[i], ep.action[i], ep.reward[i], ep.physics[i]),
            )
        done += n
        steps += n * spec.episode_length
        if agent is not None:
            save_state(out / CHECKPOINT, agent.state())
        tracker.update(ep.observation)
        elapsed = time.perf_counter() - started
        manifest.update(
            episodes=done,
            transitions=done * spec.episode_length,
            wall_seconds=round(wall_before + elapsed, 1),
        )
        write_manifest(out, manifest)
        postfix = {"steps/s": f"{steps / elapsed:.0f}", "coverage": tracker.summary()}
        if agent is not None:
            postfix["intrinsic"] = f"{agent.last_intrinsic:.3g}"
        bar.set_postfix(postfix)
        bar.update(n)
    bar.close()
    return manifest


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
