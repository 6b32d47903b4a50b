"""Oversampling the rare transitions a domain names (the maze: its doorway crossings).

An FB model learns how the maze's rooms connect only from the transitions that change room,
and RND data holds about one per 1 000-step episode (0.1 % of a batch). This builds a new
dataset: every episode of the source, plus `copies` extra copies of the window of
`window` steps on each side of every such transition (the domain's oversampling hook
cuts them), stored as short episodes. Everything downstream (FB training, Cov B, z_r,
imitation) then sees one consistent data distribution ρ, in which those transitions weigh
more; nothing else in fbil needs to know about the weights.
"""

from __future__ import annotations

import shutil
from pathlib import Path
from typing import Any

import numpy as np

from fbil.data.dataset import load_dataset, merge_datasets
from fbil.data.storage import list_episodes, load_episode, write_episode, write_manifest
from fbil.envs import DOMAINS, get_domain
from fbil.envs.hooks import Oversampling
from fbil.errors import FbilError


def domain_oversampling(src: str | Path) -> tuple[str, Oversampling]:
    """The domain of the dataset at `src` and its oversampling hook (an error where the
    domain defines none)."""
    domain = load_dataset(src, max_episodes=1).domain
    over = get_domain(domain).hooks.oversampling
    if over is None:
        defined = ", ".join(d.name for d in DOMAINS.values() if d.hooks.oversampling)
        raise FbilError(f"{src} holds {domain} data; oversampling is defined only in {defined}")
    return domain, over


def oversample_crossings(
    src: str | Path,
    out: str | Path,
    window: int = 30,
    copies: int = 4,
    command: str | None = None,
) -> dict[str, Any]:
    """Write `src` plus `copies` copies of every window the domain cuts to the new folder
    `out` (built under temporary names; a failure leaves no `out`). Returns its manifest."""
    out = Path(out)
    if window < 1 or copies < 1:
        raise FbilError(f"--window and --copies must be >= 1, got {window} and {copies}")
    if out.exists():
        raise FbilError(f"{out} already exists; choose a new --out or delete it")
    domain, over = domain_oversampling(src)
    tmp = out.with_name(f".{out.name}.windows")
    if tmp.exists():
        shutil.rmtree(tmp)
    try:
        count = 0
        for f in list_episodes(src):
            for seg in over.windows(load_episode(f.path), window):
                for _ in range(copies):  # each window's copies side by side
                    write_episode(tmp, count, seg)
                    count += 1
        if count == 0:
            raise FbilError(f"{src} has no {over.event}; nothing to oversample")
        what = f"{count // copies} windows of +-{window} steps around {src}'s {over.what}"
        write_manifest(tmp, {"domain": domain, "what": f"{what}, {copies} copies each"})
        manifest = merge_datasets(out, [src, tmp], command=command)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    manifest["merged_from"][1]["root"] = "the crossing windows"  # the temporary folder is gone
    manifest.update(crossing_windows=count // copies, window=window, copies=copies)
    write_manifest(out, manifest)
    return manifest


def copy_sources(dataset: Any) -> np.ndarray:
    """For each episode of `dataset`, the row at which its observations occur as a segment
    of a longer episode, or -1: an oversampled window (a copy of a stretch of some
    episode) does not start at an environment reset, and a method whose objective needs
    the starts (DICE's initial states) or whole episodes (OTR's transport) must know it.
    Found by looking up the episode's first observation among the rows of longer episodes
    (each distinct observation's first row, longest episodes first), then comparing the
    whole segment; a dataset without copies gives all -1."""
    obs = np.ascontiguousarray(dataset.observation)
    keys = obs.view(np.dtype((np.void, obs.dtype.itemsize * obs.shape[1]))).ravel()
    start, end = dataset.episode_start, dataset.episode_end
    lengths = end - start + 1
    owner = np.repeat(np.arange(len(start)), lengths)
    order = np.argsort(-lengths[owner], kind="stable")  # rows of the longest episodes first
    distinct, first = np.unique(keys[order], return_index=True)  # first: in that order
    pos = np.minimum(np.searchsorted(distinct, keys[start]), len(distinct) - 1)
    row = order[first[pos]]  # where each episode's first observation occurs first
    sources = np.full(len(start), -1, dtype=np.int64)
    candidates = (distinct[pos] == keys[start]) & (lengths[owner[row]] > lengths)
    for e in np.flatnonzero(candidates):
        r, n = row[e], lengths[e]
        if r + n <= end[owner[r]] + 1 and np.array_equal(
            obs[r : r + n], obs[start[e] : end[e] + 1]
        ):
            sources[e] = r
    return sources
