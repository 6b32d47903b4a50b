"""Episodes on disk in ExORL's layout, so fbil reads real ExORL folders unchanged.

A dataset folder holds `buffer/<timestamp>_<idx>_<len>.npz`, one episode per file, with
arrays `observation`, `action`, `reward`, `discount`, `physics` of length T+1; index 0 is
the reset step (zero action, zero reward). Transition t >= 1 is
(observation[t-1], action[t], observation[t]) and physics[t] is the state it reached.
Folders fbil writes also hold `manifest.json`.
"""

from __future__ import annotations

import datetime
import io
import json
import re
import zipfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from fbil.checkpoint import atomic_write_text
from fbil.errors import FbilError

KEYS = ("observation", "action", "reward", "discount", "physics")
_NAME = re.compile(r"^(\d{8}T\d{6})_(\d+)_(\d+)\.npz$")


@dataclass(frozen=True)
class EpisodeFile:
    path: Path
    index: int
    length: int  # transitions (T), as in the file name


def buffer_dir(root: str | Path) -> Path:
    """`root/buffer`, or `root` itself when it already is a buffer folder."""
    root = Path(root)
    return root if root.name == "buffer" else root / "buffer"


def list_episodes(root: str | Path) -> list[EpisodeFile]:
    """Episode files of a dataset folder, by episode index."""
    buf = buffer_dir(root)
    if not buf.is_dir():
        raise FbilError(f"no dataset at {root}: expected episode files in {buf}/*.npz")
    files = []
    for p in buf.iterdir():
        m = _NAME.match(p.name)
        if m:
            files.append(EpisodeFile(p, int(m.group(2)), int(m.group(3))))
    return sorted(files, key=lambda f: (f.index, f.path.name))


def episode_name(index: int, length: int, when: datetime.datetime | None = None) -> str:
    stamp = (when or datetime.datetime.now()).strftime("%Y%m%dT%H%M%S")
    return f"{stamp}_{index}_{length}.npz"


def write_episode(root: str | Path, index: int, episode: dict[str, np.ndarray]) -> Path:
    """Write one episode atomically (temp file + rename): a kill never leaves a partial
    file under an episode's name."""
    missing = [k for k in KEYS if k not in episode]
    if missing:
        raise FbilError(f"episode lacks array(s) {', '.join(missing)}")
    length = len(episode["observation"]) - 1
    buf = buffer_dir(root)
    buf.mkdir(parents=True, exist_ok=True)
    path = buf / episode_name(index, length)
    tmp = buf / f".{path.name}.tmp"
    with io.BytesIO() as bs:
        np.savez_compressed(bs, allow_pickle=False, **episode)
        tmp.write_bytes(bs.getvalue())
    tmp.replace(path)
    return path


def load_episode(path: str | Path, keys: tuple[str, ...] = KEYS) -> dict[str, np.ndarray]:
    """Read arrays `keys` of one episode file and check them (every array of the layout
    must be present); any defect is a one-line error naming the file."""
    path = Path(path)
    if path.is_file() and not zipfile.is_zipfile(path):
        raise FbilError(f"{path}: not an .npz archive; delete it and re-collect")
    try:
        with np.load(path, allow_pickle=False) as npz:
            missing = [k for k in KEYS if k not in npz.files]
            if missing:
                raise FbilError(
                    f"{path}: missing array(s) {', '.join(missing)}; an episode file needs "
                    f"{', '.join(KEYS)}"
                )
            ep = {k: npz[k] for k in keys}
    except FbilError:
        raise
    except (OSError, ValueError, EOFError, zipfile.BadZipFile) as exc:
        raise FbilError(
            f"{path}: corrupt or truncated episode file ({exc}); delete it and re-collect"
        ) from None
    lengths = {k: len(v) for k, v in ep.items()}
    if len(set(lengths.values())) != 1:
        raise FbilError(
            f"{path}: arrays have mismatched lengths {lengths}; every array needs T+1 rows"
        )
    if next(iter(lengths.values())) < 2:
        raise FbilError(f"{path}: episode has no transition (needs at least 2 rows)")
    for k, v in ep.items():
        if not np.all(np.isfinite(v)):
            raise FbilError(f"{path}: array {k!r} contains NaN or inf")
    return ep


def read_manifest(root: str | Path) -> dict[str, Any] | None:
    p = Path(root) / "manifest.json"
    if not p.is_file():
        return None
    try:
        data = json.loads(p.read_text())
    except json.JSONDecodeError as exc:
        raise FbilError(f"{p}: not valid JSON ({exc}); fix or delete it") from None
    assert isinstance(data, dict)
    return data


def write_manifest(root: str | Path, manifest: dict[str, Any]) -> Path:
    return atomic_write_text(Path(root) / "manifest.json", json.dumps(manifest, indent=2) + "\n")


def episode_arrays(
    observation: np.ndarray, action: np.ndarray, reward: np.ndarray, physics: np.ndarray
) -> dict[str, np.ndarray]:
    """One rollout (obs T+1, action T, reward T, physics T+1) in ExORL's T+1 layout: row 0
    is the reset step, with a zero action, zero reward and discount 1."""
    n = len(observation)
    return {
        "observation": np.asarray(observation, np.float32),
        "action": np.concatenate([np.zeros((1, action.shape[1]), np.float32), action]),
        "reward": np.concatenate([[0.0], reward]).astype(np.float32).reshape(n, 1),
        "discount": np.ones((n, 1), np.float32),
        "physics": np.asarray(physics, np.float64),
    }
