"""Checkpoints as safetensors + JSON, written atomically, never pickled.

A state is a nested dict whose leaves are tensors (stored in the safetensors file) or
JSON values (stored in its metadata). Optimizer state dicts, module state dicts, RNG
states and step counters all fit, which is what exact resumption needs.
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import torch
from safetensors import SafetensorError
from safetensors.torch import load_file, save_file

from fbil.errors import FbilError

_SEP = "/"


def _flatten(state: Any, prefix: str, tensors: dict[str, torch.Tensor]) -> Any:
    """Move tensors out of `state` into `tensors`; return the JSON skeleton."""
    if isinstance(state, torch.Tensor):
        tensors[prefix] = state.detach().cpu().contiguous()
        return {"__tensor__": prefix}
    if isinstance(state, np.ndarray):
        tensors[prefix] = torch.from_numpy(np.ascontiguousarray(state))
        return {"__ndarray__": prefix}
    if isinstance(state, dict):
        return {
            "__dict__": [
                [
                    _flatten(k, "", {}) if not isinstance(k, str) else k,
                    _flatten(v, f"{prefix}{_SEP}{k}", tensors),
                ]
                for k, v in state.items()
            ]
        }
    if isinstance(state, list | tuple):
        items = [_flatten(v, f"{prefix}{_SEP}{i}", tensors) for i, v in enumerate(state)]
        return {"__list__": items} if isinstance(state, list) else {"__tuple__": items}
    if isinstance(state, np.integer | np.floating):
        return state.item()
    return state  # int, float, str, bool, None


def _unflatten(skeleton: Any, tensors: dict[str, torch.Tensor]) -> Any:
    if isinstance(skeleton, dict):
        if "__tensor__" in skeleton:
            return tensors[skeleton["__tensor__"]]
        if "__ndarray__" in skeleton:
            return tensors[skeleton["__ndarray__"]].numpy()
        if "__dict__" in skeleton:
            return {
                (k if isinstance(k, str) else _unflatten(k, tensors)): _unflatten(v, tensors)
                for k, v in skeleton["__dict__"]
            }
        if "__list__" in skeleton:
            return [_unflatten(v, tensors) for v in skeleton["__list__"]]
        if "__tuple__" in skeleton:
            return tuple(_unflatten(v, tensors) for v in skeleton["__tuple__"])
    return skeleton


def save_state(path: str | Path, state: dict[str, Any]) -> Path:
    """Write `state` to `path` (a .safetensors file) atomically: temp file + rename."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tensors: dict[str, torch.Tensor] = {}
    skeleton = _flatten(state, "", tensors)
    tmp = path.with_name(f".{path.name}.tmp")
    save_file(tensors, str(tmp), metadata={"fbil_state": json.dumps(skeleton)})
    with open(tmp, "rb") as f:
        os.fsync(f.fileno())
    tmp.replace(path)
    return path


def load_state(path: str | Path) -> dict[str, Any]:
    """Read a state written by `save_state`; a missing or corrupt file is a one-line error."""
    path = Path(path)
    if not path.is_file():
        raise FbilError(f"no checkpoint at {path}")
    try:
        from safetensors import safe_open

        with safe_open(str(path), framework="pt") as f:
            meta = f.metadata() or {}
        tensors = load_file(str(path))
        skeleton = json.loads(meta["fbil_state"])
    except (SafetensorError, KeyError, json.JSONDecodeError, OSError) as exc:
        raise FbilError(f"corrupt checkpoint {path}: {exc}; delete it or retrain") from None
    state = _unflatten(skeleton, tensors)
    assert isinstance(state, dict)
    return state


def atomic_write_text(path: str | Path, text: str) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text(text)
    tmp.replace(path)
    return path


@dataclass
class FitCheckpoint:
    """Exact resumption of one imitation fit (a baseline's training loop) after a kill.

    The loop calls `resume(phase)` once, before its first update, and `tick` after each
    update; every `every` seconds, and after the last update, `tick` writes the loop's whole
    state to `path`. `signature` names what is trained (the job, its settings, the data):
    a file of another signature or phase is left alone and replaced at the next save. The
    time to policy (`seconds`) adds the fit seconds that earlier processes had reached to
    this process's since its resume, so work redone before the resume is not counted twice.
    """

    path: Path
    signature: str
    every: float = 180.0
    resumed_at: list[int] = field(default_factory=list)  # the steps this fit resumed from
    _started: float = field(default_factory=time.perf_counter)
    _saved: float = field(default_factory=time.perf_counter)
    _prior: float | None = None  # fit seconds of earlier processes, once resumed
    _resumed: float = 0.0

    def begin(self) -> None:
        """The fit starts in this process (its clock starts here)."""
        self._started = self._saved = time.perf_counter()

    def seconds(self) -> float:
        """The fit's seconds so far, over every process that worked on it."""
        now = time.perf_counter()
        return now - self._started if self._prior is None else self._prior + now - self._resumed

    def resume(self, phase: str) -> tuple[int, dict[str, Any], dict[str, float]] | None:
        """(the last saved step, the agent's state, the last update's numbers) of
        `phase`, or None: start afresh."""
        if not self.path.is_file():
            return None
        try:
            saved = load_state(self.path)
        except FbilError:  # unreadable: start over (the next save replaces it)
            return None
        if saved.get("signature") != self.signature or saved.get("phase") != phase:
            return None
        self._prior, self._resumed = float(saved["seconds"]), time.perf_counter()
        self.resumed_at.append(int(saved["step"]))
        return int(saved["step"]), saved["agent"], dict(saved["info"])

    def tick(
        self,
        phase: str,
        step: int,
        steps: int,
        agent: Callable[[], dict[str, Any]],
        info: dict[str, float],
    ) -> None:
        """After update `step` of `steps`: save the agent's state (`agent()`, called only
        then) and the update's numbers `info` when due, and always after the last one."""
        if step < steps and time.perf_counter() - self._saved < self.every:
            return
        entry = {"signature": self.signature, "phase": phase, "step": step, "info": info}
        save_state(self.path, {**entry, "seconds": self.seconds(), "agent": agent()})
        self._saved = time.perf_counter()

    def discard(self) -> None:
        """The fit's result is safe elsewhere: remove the file."""
        self.path.unlink(missing_ok=True)
