"""Expert demonstrations: one npz file holding one or many trajectories.

Arrays are concatenated over trajectories with `offsets` marking where each trajectory's
states begin: `observation` (sum of T_i + 1 rows), optional `action` (sum of T_i rows),
optional `reward` (sum of T_i) and `physics` (like observation, or only the rows of the
trajectories listed in `physics_of`); `metadata` is a JSON string (domain, task, source,
expert returns, ...).
"""

from __future__ import annotations

import io
import json
import zipfile
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from fbil.errors import FbilError

DEMO_PHYSICS = ("all", "first", "none")  # which demos of a file keep their physics states


def check_physics(which: str) -> str:
    """`which` if it names a DEMO_PHYSICS choice, else one FbilError line."""
    if which not in DEMO_PHYSICS:
        raise FbilError(f"unknown --physics {which!r}; valid: {', '.join(DEMO_PHYSICS)}")
    return which


@dataclass
class Trajectory:
    observation: np.ndarray  # (T+1, obs_dim)
    action: np.ndarray | None = None  # (T, act_dim)
    reward: np.ndarray | None = None  # (T,)
    physics: np.ndarray | None = None  # (T+1, physics_dim)

    def __len__(self) -> int:
        return len(self.observation) - 1


@dataclass
class Demos:
    trajectories: list[Trajectory]
    metadata: dict[str, Any] = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.trajectories)

    @property
    def has_actions(self) -> bool:
        return all(t.action is not None for t in self.trajectories)

    @property
    def obs_dim(self) -> int:
        return int(self.trajectories[0].observation.shape[1])

    def select(self, indices: Sequence[int]) -> Demos:
        return Demos([self.trajectories[i] for i in indices], dict(self.metadata))

    def validate(
        self, obs_dim: int | None = None, act_dim: int | None = None, source: str = "demos"
    ) -> Demos:
        """Check shapes and values; every problem is a one-line FbilError."""
        if not self.trajectories:
            raise FbilError(f"{source}: no trajectories (need at least one demonstration)")
        for i, t in enumerate(self.trajectories):
            where = f"{source}: trajectory {i}"
            obs = np.asarray(t.observation)
            if obs.ndim != 2 or len(obs) < 2:
                raise FbilError(
                    f"{where}: needs at least two states as a (T+1, obs_dim) array, "
                    f"got shape {obs.shape}"
                )
            if obs_dim is not None and obs.shape[1] != obs_dim:
                raise FbilError(
                    f"{where}: states have {obs.shape[1]} dimensions, the model "
                    f"expects {obs_dim} (demos of another domain?)"
                )
            if not np.all(np.isfinite(obs)):
                raise FbilError(f"{where}: observation contains NaN or inf")
            if t.action is not None:
                act = np.asarray(t.action)
                if act.ndim != 2 or len(act) != len(obs) - 1:
                    raise FbilError(
                        f"{where}: action must be (T, act_dim) with T = "
                        f"{len(obs) - 1}, got shape {act.shape}"
                    )
                if act_dim is not None and act.shape[1] != act_dim:
                    raise FbilError(
                        f"{where}: actions have {act.shape[1]} dimensions, the model "
                        f"expects {act_dim}"
                    )
                if not np.all(np.isfinite(act)):
                    raise FbilError(f"{where}: action contains NaN or inf")
        return self

    def keep_physics(self, which: str) -> Demos:
        """The same demos with physics states kept for `which` of them: all (exact reward
        relabeling), first (only the demo the report and `fbil demo` draw; a file about
        half the size) or none. Everything else is shared, not copied."""
        kept = {"all": len(self), "first": 1, "none": 0}[check_physics(which)]
        missing = [i for i, t in enumerate(self.trajectories[:kept]) if t.physics is None]
        if missing:
            raise FbilError(f"demo {missing[0]} has no physics states to keep (--physics {which})")
        trajs = [
            t if i < kept else replace(t, physics=None) for i, t in enumerate(self.trajectories)
        ]
        return Demos(trajs, dict(self.metadata))

    # -- files ----------------------------------------------------------------------------
    def save(self, path: str | Path) -> Path:
        path = Path(path)
        arrays: dict[str, np.ndarray] = {
            "observation": np.concatenate([t.observation for t in self.trajectories]).astype(
                np.float32
            ),
            "offsets": np.cumsum([0] + [len(t.observation) for t in self.trajectories]),
            "metadata": np.array(json.dumps(self.metadata)),
        }
        for key in ("action", "reward"):
            parts = [getattr(t, key) for t in self.trajectories]
            if all(p is not None for p in parts):
                arrays[key] = np.concatenate(parts)
        kept = [i for i, t in enumerate(self.trajectories) if t.physics is not None]
        if kept:
            arrays["physics"] = np.concatenate([self.trajectories[i].physics for i in kept])
            if len(kept) < len(self.trajectories):
                arrays["physics_of"] = np.asarray(kept)  # the trajectories that keep theirs
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(f".{path.name}.tmp")
        with io.BytesIO() as bs:
            np.savez_compressed(bs, allow_pickle=False, **arrays)
            tmp.write_bytes(bs.getvalue())
        tmp.replace(path)
        return path

    @classmethod
    def load(cls, path: str | Path) -> Demos:
        path = Path(path)
        data = _read_npz(path)
        offsets = _checked_offsets(path, data)
        steps = np.diff(offsets) - 1
        act_offsets = np.concatenate([[0], np.cumsum(steps)])
        physics = _physics_by_trajectory(path, data, offsets)
        trajs = []
        for i in range(len(offsets) - 1):
            s, e = offsets[i], offsets[i + 1]
            a, b = act_offsets[i], act_offsets[i + 1]
            trajs.append(
                Trajectory(
                    observation=data["observation"][s:e],
                    action=data["action"][a:b] if "action" in data else None,
                    reward=data["reward"][a:b] if "reward" in data else None,
                    physics=physics[i],
                )
            )
        try:
            meta = json.loads(str(data.get("metadata", "{}")))
        except json.JSONDecodeError:
            meta = {}
        return cls(trajs, meta).validate(source=str(path))


def _read_npz(path: Path) -> dict[str, np.ndarray]:
    """The arrays of a demo .npz, or one FbilError line saying why there are none."""
    if not path.is_file():
        raise FbilError(
            f"no demonstrations at {path}; pass a demo .npz (e.g. one of "
            "artifacts/demos/<domain>/, or one written by `fbil demos`)"
        )
    if not zipfile.is_zipfile(path):
        raise FbilError(
            f"{path}: not an .npz archive (a demo file is written by `fbil demos` or "
            "`Demos.save`); check the path"
        )
    try:
        with np.load(path, allow_pickle=False) as npz:
            return {k: npz[k] for k in npz.files}
    except (OSError, ValueError, EOFError, zipfile.BadZipFile) as exc:
        raise FbilError(f"{path}: not a readable demo file ({exc})") from None


def _checked_offsets(path: Path, data: dict[str, np.ndarray]) -> np.ndarray:
    """`offsets` as integers, checked against the observation rows they cut."""
    if "observation" not in data or "offsets" not in data:
        raise FbilError(f"{path}: not a demo file (needs arrays observation and offsets)")
    offsets, obs = data["offsets"], data["observation"]
    rows = len(obs) if obs.ndim else 0
    if offsets.ndim != 1 or not np.issubdtype(offsets.dtype, np.integer):
        raise FbilError(f"{path}: offsets must be a 1-D integer array, got {offsets.dtype}")
    if len(offsets) and (offsets[0] != 0 or offsets[-1] != rows or np.any(np.diff(offsets) < 1)):
        shown = str(offsets.tolist()[:4])[:-1] + (", ...]" if len(offsets) > 4 else "]")
        raise FbilError(
            f"{path}: offsets {shown} must rise from 0 to the "
            f"{rows} observation rows; the file is damaged or was not written by fbil"
        )
    return offsets.astype(int)


def _physics_by_trajectory(
    path: Path, data: dict[str, np.ndarray], offsets: np.ndarray
) -> list[np.ndarray | None]:
    """Each trajectory's physics states: all of them (`physics` alone), those `physics_of`
    names (a file that keeps physics for some demos only, `fbil demos --physics first`),
    or none."""
    n = len(offsets) - 1
    if "physics" not in data:
        return [None] * n
    of = data["physics_of"] if "physics_of" in data else np.arange(n)
    lengths = np.diff(offsets)
    fits = of.ndim == 1 and np.issubdtype(of.dtype, np.integer) and len(of) > 0
    fits = fits and bool(np.all(np.diff(of) > 0)) and of[0] >= 0 and of[-1] < n
    if not fits or len(data["physics"]) != lengths[of].sum():
        raise FbilError(
            f"{path}: its physics rows do not match the trajectories they belong to; the "
            "file is damaged or was not written by fbil"
        )
    out: list[np.ndarray | None] = [None] * n
    starts = np.concatenate([[0], np.cumsum(lengths[of])])
    for j, i in enumerate(of):
        out[int(i)] = data["physics"][starts[j] : starts[j + 1]]
    return out


def from_arrays(
    observations: Sequence[np.ndarray],
    actions: Sequence[np.ndarray] | None = None,
    metadata: dict[str, Any] | None = None,
) -> Demos:
    """Demos from plain arrays: one (T+1, obs_dim) array per trajectory (and actions)."""
    trajs = [
        Trajectory(
            np.asarray(o, np.float32),
            None if actions is None else np.asarray(actions[i], np.float32),
        )
        for i, o in enumerate(observations)
    ]
    return Demos(trajs, dict(metadata or {})).validate()


def from_episodes(ep: Any, metadata: dict[str, Any]) -> Demos:
    """One demo per episode of a `BatchedEnv.rollout` result (`fbil.envs.Episodes`), with
    `metadata` plus the episodes' returns, their mean and standard deviation."""
    trajs = [
        Trajectory(ep.observation[i], ep.action[i], ep.reward[i].astype(np.float32), ep.physics[i])
        for i in range(len(ep.returns))
    ]
    returns = np.asarray(ep.returns)
    return Demos(
        trajs,
        {
            **metadata,
            "returns": returns.tolist(),
            "return_mean": float(returns.mean()),
            "return_std": float(returns.std()),
        },
    )


def from_imitation(trajectories: Sequence[Any], metadata: dict[str, Any] | None = None) -> Demos:
    """Demos from the `imitation` library's Trajectory objects (fields obs, acts)."""
    return from_arrays(
        [np.asarray(t.obs) for t in trajectories],
        [np.asarray(t.acts) for t in trajectories],
        metadata,
    )
