"""Oversampling the maze's doorway crossings.

An FB model learns how the maze's rooms connect only from the transitions that change room,
and RND data holds about one per 1 000-step episode (0.1 % of a batch). This builds a new
dataset: every episode of the source, plus `copies` extra copies of the window of
`window` steps on each side of every crossing, stored as short episodes. Everything
downstream (FB training, Cov B, z_r, imitation) then sees one consistent data distribution
ρ, in which the doorways weigh more; nothing else in fbil needs to know about the weights.
"""

from __future__ import annotations

import shutil
from pathlib import Path
from typing import Any

import numpy as np

from fbil.data.dataset import load_dataset, merge_datasets
from fbil.data.storage import list_episodes, load_episode, write_episode, write_manifest
from fbil.envs import maze
from fbil.errors import FbilError


def crossing_windows(episode: dict[str, np.ndarray], window: int) -> list[dict[str, np.ndarray]]:
    """The rows [t - window - 1, t + window] around each row t reached by a room change, as
    episodes of their own (row 0 becomes the reset row: zero action and reward)."""
    room = maze.room_of(episode["observation"][:, :2])
    reached = np.flatnonzero(room[1:] != room[:-1]) + 1
    out = []
    for t in reached:
        lo, hi = max(0, t - window - 1), min(len(room), t + window + 1)
        seg = {k: np.array(v[lo:hi]) for k, v in episode.items()}
        seg["action"][0] = 0
        seg["reward"][0] = 0
        out.append(seg)
    return out


def oversample_crossings(
    src: str | Path,
    out: str | Path,
    window: int = 30,
    copies: int = 4,
    command: str | None = None,
) -> dict[str, Any]:
    """Write `src` plus `copies` copies of every crossing window to the new folder `out`
    (built under temporary names; a failure leaves no `out`). Returns out's manifest."""
    out = Path(out)
    if window < 1 or copies < 1:
        raise FbilError(f"--window and --copies must be >= 1, got {window} and {copies}")
    if out.exists():
        raise FbilError(f"{out} already exists; choose a new --out or delete it")
    domain = load_dataset(src, max_episodes=1).domain
    if domain != "point_mass_maze":
        raise FbilError(
            f"{src} holds {domain} data; doorway crossings exist only in point_mass_maze"
        )
    tmp = out.with_name(f".{out.name}.windows")
    if tmp.exists():
        shutil.rmtree(tmp)
    try:
        count = 0
        for f in list_episodes(src):
            for seg in crossing_windows(load_episode(f.path), window):
                for _ in range(copies):  # each window's copies side by side
                    write_episode(tmp, count, seg)
                    count += 1
        if count == 0:
            raise FbilError(f"{src} has no transition that changes room; nothing to oversample")
        what = f"{count // copies} windows of +-{window} steps around {src}'s doorway crossings"
        write_manifest(tmp, {"domain": domain, "what": f"{what}, {copies} copies each"})
        manifest = merge_datasets(out, [src, tmp], command=command)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    manifest["merged_from"][1]["root"] = "the crossing windows"  # the temporary folder is gone
    manifest.update(crossing_windows=count // copies, window=window, copies=copies)
    write_manifest(out, manifest)
    return manifest
