"""Policy files written by `fbil imitate --out` (or `Policy.save`), read back as policies.

The file's format says what it holds: `.safetensors`, a trained network of an offline-IL
baseline (it acts alone); `.json` with `z`, an FB-IL policy (it acts through the FB model
it was inferred from, which the caller passes); `.json` with `goals`, a goal-tracking
policy (it names its goal model's folder)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from fbil.errors import FbilError
from fbil.imitators.base import Policy


def load_policy(path: str | Path, model: Any = None) -> Policy:
    """The policy saved at `path`; `model`: the FB model (`FBModel`) for FB-IL files."""
    path = Path(path)
    if not path.is_file():
        raise FbilError(f"no policy file at {path}; write one with `fbil imitate ... --out DIR`")
    if path.suffix == ".safetensors":
        from fbil.baselines.common import load_trained_policy

        return load_trained_policy(path)
    if path.suffix != ".json":
        raise FbilError(f"{path}: unknown policy file type; expected .json or .safetensors")
    try:
        body = json.loads(path.read_text())
    except (OSError, json.JSONDecodeError) as exc:
        raise FbilError(f"{path}: not a policy file ({exc})") from None
    if isinstance(body, dict) and "goals" in body:
        from fbil.baselines.goal_td3 import GoalTrackingPolicy

        return GoalTrackingPolicy.load(path)
    if not isinstance(body, dict) or "z" not in body:
        raise FbilError(f"{path}: not a policy file (no z, goals or network)")
    if model is None:
        raise FbilError(
            f"{path} holds an FB-IL policy ({body.get('method', '?')}), which acts through "
            "its FB model: pass the model folder (--model DIR)"
        )
    from fbil.imitation.core import ImitationPolicy

    return ImitationPolicy.load(path, model)
