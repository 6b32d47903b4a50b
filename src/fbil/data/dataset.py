"""An unsupervised dataset in memory: one contiguous float32 array per field.

States of all episodes are stacked (T+1 rows each, the reset row included), so transition
j (for every non-reset row j) is (observation[j-1], action[j], observation[j]). Physics
states are only read when a task's rewards are first needed; the domain quantities they
give are cached next to the data, so relabeling a dataset for another task is instant.
"""

from __future__ import annotations

import hashlib
import os
import shutil
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from fbil import __version__
from fbil.data.storage import (
    EpisodeFile,
    list_episodes,
    load_episode,
    read_manifest,
    write_manifest,
)
from fbil.envs import DOMAINS, compute_quantities, get_domain, get_task, task_reward
from fbil.envs.base import Quantities
from fbil.errors import FbilError


@dataclass
class TransitionBatch:
    obs: np.ndarray
    action: np.ndarray
    next_obs: np.ndarray
    discount: np.ndarray
    index: np.ndarray  # row of next_obs in the dataset (for future states and physics)


def infer_domain(obs_dim: int, act_dim: int, physics_dim: int) -> str | None:
    for d in DOMAINS.values():
        if (d.obs_dim, d.act_dim, d.physics_dim) == (obs_dim, act_dim, physics_dim):
            return d.name
    return None


class Dataset:
    def __init__(
        self,
        root: Path,
        domain: str,
        files: list[EpisodeFile],
        observation: np.ndarray,
        action: np.ndarray,
        discount: np.ndarray,
        episode_start: np.ndarray,
    ) -> None:
        self.root, self.domain, self.files = root, domain, files
        self.observation, self.action, self.discount = observation, action, discount
        self.episode_start = episode_start
        n_states = len(observation)
        self.episode_end = np.append(episode_start[1:], n_states) - 1  # inclusive
        lengths = self.episode_end - self.episode_start + 1
        self.state_episode_end = np.repeat(self.episode_end, lengths)
        is_reset = np.zeros(n_states, bool)
        is_reset[episode_start] = True
        self.next_index = np.flatnonzero(~is_reset)
        self._quantities: Quantities | None = None
        self._rewards: dict[str, np.ndarray] = {}
        self._digest: str | None = None

    # -- sizes -----------------------------------------------------------------------
    @property
    def num_episodes(self) -> int:
        return len(self.episode_start)

    @property
    def num_transitions(self) -> int:
        return len(self.next_index)

    def __len__(self) -> int:
        return self.num_transitions

    # -- sampling --------------------------------------------------------------------
    def sample(self, batch_size: int, rng: np.random.Generator) -> TransitionBatch:
        j = self.next_index[rng.integers(0, self.num_transitions, batch_size)]
        return TransitionBatch(
            self.observation[j - 1], self.action[j], self.observation[j], self.discount[j], j
        )

    def sample_future(
        self, index: np.ndarray, gamma: float, rng: np.random.Generator
    ) -> np.ndarray:
        """Rows of future states of the same episode, offset ~ Geometric(1 - gamma) - 1,
        clipped at the episode's last state."""
        offset = rng.geometric(1.0 - gamma, size=len(index)) - 1
        return np.minimum(index + offset, self.state_episode_end[index])

    def sample_states(self, n: int, rng: np.random.Generator) -> np.ndarray:
        """Rows of states drawn uniformly from the whole dataset."""
        return self.next_index[rng.integers(0, self.num_transitions, n)]

    # -- rewards -----------------------------------------------------------------------
    def physics(self) -> np.ndarray:
        """Physics states of every row (read from disk on demand: they are large)."""
        out = np.empty((len(self.observation), get_domain(self.domain).physics_dim))
        for f, start, end in zip(self.files, self.episode_start, self.episode_end, strict=True):
            out[start : end + 1] = load_episode(f.path, ("physics",))["physics"]
        return out

    def quantities(self) -> Quantities:
        """Domain quantities of every transition (rows `next_index`), cached on disk."""
        if self._quantities is None:
            cache = self.root / "cache" / f"quantities_{self._fingerprint()}.npz"
            if cache.is_file():
                with np.load(cache) as npz:
                    self._quantities = {k: npz[k] for k in npz.files}
            else:
                j = self.next_index
                self._quantities = compute_quantities(
                    self.domain, self.physics()[j], self.action[j]
                )
                try:
                    cache.parent.mkdir(exist_ok=True)
                    tmp = cache.with_name(f".{cache.name}.tmp.npz")
                    np.savez(tmp, allow_pickle=False, **self._quantities)
                    tmp.replace(cache)
                except OSError:
                    pass  # a read-only dataset folder just is not cached
        return self._quantities

    def reward(self, task: str) -> np.ndarray:
        """Reward of `task` for every transition (aligned with `next_index`), float32."""
        get_task(self.domain, task)
        if task not in self._rewards:
            r = task_reward(self.domain, task, self.quantities())
            self._rewards[task] = r.astype(np.float32)
        return self._rewards[task]

    def digest(self) -> str:
        """16 hex digits of sha256 over observations, actions, discounts, episode starts: equal for
        two copies of one dataset, different for a regeneration that drifted (another CPU)."""
        if self._digest is None:
            h = hashlib.sha256()
            for a in (self.observation, self.action, self.discount, self.episode_start):
                h.update(np.ascontiguousarray(a).tobytes())
            self._digest = h.hexdigest()[:16]
        return self._digest

    def _fingerprint(self) -> str:
        names = "\n".join(f.path.name for f in self.files)
        return hashlib.sha256(names.encode()).hexdigest()[:16]


def load_dataset(
    root: str | Path, domain: str | None = None, max_episodes: int | None = None
) -> Dataset:
    """Load an ExORL-layout folder (fbil's or ExORL's own). `domain`, when given, must
    match the data; otherwise it is read from the manifest or inferred from the sizes."""
    root = Path(root)
    files = list_episodes(root)
    if not files:
        raise FbilError(
            f"no episodes in {root}: expected files <timestamp>_<idx>_<len>.npz in "
            f"{root / 'buffer'}"
        )
    if max_episodes is not None:
        files = files[:max_episodes]
    first = load_episode(files[0].path)
    dims = (first["observation"].shape[1], first["action"].shape[1], first["physics"].shape[1])
    manifest = read_manifest(root if root.name != "buffer" else root.parent) or {}
    found = manifest.get("domain") or infer_domain(*dims)
    if domain is not None:
        spec = get_domain(domain)
        if found != domain or dims != (spec.obs_dim, spec.act_dim, spec.physics_dim):
            raise FbilError(
                f"{root} holds {found or 'unknown'} data (obs {dims[0]}, action {dims[1]}, "
                f"physics {dims[2]}), not {domain} (obs {spec.obs_dim}, action "
                f"{spec.act_dim}, physics {spec.physics_dim}); pass the matching dataset"
            )
    elif found is None:
        raise FbilError(
            f"{root}: cannot tell the domain (obs {dims[0]}, action {dims[1]}, physics "
            f"{dims[2]} match none of {', '.join(DOMAINS)}); pass the domain explicitly"
        )
    else:
        domain = found
    sizes = [f.length + 1 for f in files]
    n_states = int(sum(sizes))
    obs = np.empty((n_states, dims[0]), np.float32)
    act = np.empty((n_states, dims[1]), np.float32)
    disc = np.empty(n_states, np.float32)
    starts = np.zeros(len(files), np.int64)
    row = 0
    for i, f in enumerate(files):
        ep = first if i == 0 else load_episode(f.path, ("observation", "action", "discount"))
        n = len(ep["observation"])
        if n != f.length + 1:
            raise FbilError(
                f"{f.path}: holds {n} rows but its name says {f.length} transitions "
                f"({f.length + 1} rows); the file is damaged or misnamed"
            )
        if ep["observation"].shape[1] != dims[0] or ep["action"].shape[1] != dims[1]:
            raise FbilError(f"{f.path}: array widths differ from the dataset's first episode")
        starts[i] = row
        obs[row : row + n] = ep["observation"]
        act[row : row + n] = ep["action"]
        disc[row : row + n] = np.asarray(ep["discount"]).reshape(n)
        row += n
    return Dataset(root, domain, files, obs, act, disc, starts)


_Part = tuple[Path, list[EpisodeFile], dict[str, Any]]


def merge_datasets(
    out: str | Path, sources: list[str | Path], command: str | None = None
) -> dict[str, Any]:
    """One dataset folder holding the episodes of several (e.g. RND from the standard
    start and RND from uniform starts), renumbered in the order given. Files are
    hard-linked where the file system allows (else copied); the folder is built under a
    temporary name and renamed, so a failure never leaves a half-merged `out`. Every
    source must hold the same domain; the manifest lists each source's own manifest."""
    out = Path(out)
    if out.exists():
        raise FbilError(f"{out} already exists; choose a new --out or delete it")
    if len(sources) < 2:
        raise FbilError("merging needs at least two dataset folders")
    parts, domain = _merge_sources(sources)
    tmp = out.with_name(f".{out.name}.merging")
    if tmp.exists():
        shutil.rmtree(tmp)
    buf = tmp / "buffer"
    buf.mkdir(parents=True)
    try:
        listing, episodes = _link_episodes(parts, buf)
    except OSError as exc:
        shutil.rmtree(tmp, ignore_errors=True)
        raise FbilError(f"cannot write {out} ({exc}); check the disk and permissions") from None
    merged = {
        "domain": domain,
        "merged_from": listing,
        "episodes": episodes,
        "fbil_version": __version__,
        "reward": "none (reward-free; relabel with a task)",
    }
    if command:
        merged["command"] = command
    write_manifest(tmp, merged)
    tmp.rename(out)
    return merged


def _merge_sources(sources: list[str | Path]) -> tuple[list[_Part], str]:
    """Each source's folder, episode files and manifest, and the one domain they share."""
    parts: list[_Part] = []
    domains: list[str] = []
    for src in sources:
        root = Path(src)
        files = list_episodes(root)
        if not files:
            raise FbilError(f"no episodes in {root}: nothing to merge")
        manifest = read_manifest(root) or {}
        found = manifest.get("domain")
        if found is None:  # an ExORL folder without a manifest: tell by the array widths
            keys = ("observation", "action", "physics")
            first = load_episode(files[0].path, keys)
            found = infer_domain(*(first[k].shape[1] for k in keys))
        parts.append((root, files, manifest))
        domains.append(str(found))
    if len(set(domains)) != 1 or "None" in domains:
        named = ", ".join(f"{p[0]} ({d})" for p, d in zip(parts, domains, strict=True))
        raise FbilError(f"cannot merge datasets of different or unknown domains: {named}")
    return parts, domains[0]


def _link_episodes(parts: list[_Part], buf: Path) -> tuple[list[dict[str, Any]], int]:
    """Hard-link (else copy) every episode file into `buf`, renumbered in order; the
    manifest's listing of the sources and the number of episodes."""
    index = 0
    listing = []
    for root, files, manifest in parts:
        for f in files:
            stamp = f.path.name.split("_")[0]  # list_episodes matched <stamp>_<idx>_<len>
            target = buf / f"{stamp}_{index}_{f.length}.npz"
            try:
                os.link(f.path, target)
            except OSError:
                shutil.copyfile(f.path, target)
            index += 1
        listing.append({"root": str(root), "episodes": len(files), "manifest": manifest})
    return listing, index
