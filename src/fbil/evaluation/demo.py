"""`fbil demo`: the whole job on the shipped maze model, in about a minute.

Loads the committed `cpu` maze FB model and one committed expert demonstration (both
checked against their manifests), imitates it with every FB-IL method, evaluates each
policy with the batched engine, prints a table and draws the demonstration against each
method's rollout over the maze walls."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from fbil.errors import FbilError

DEFAULT_TASK = "loop"  # a path to follow, where the principles visibly differ
DEFAULT_OUT = "runs/demo"  # runs/ is gitignored: the demo leaves no untracked files


def artifacts_root() -> Path:
    """FBIL_ARTIFACTS, else the checkout's artifacts/ (fbil is installed from a clone)."""
    env = os.environ.get("FBIL_ARTIFACTS")
    return Path(env) if env else Path(__file__).resolve().parents[3] / "artifacts"


def _artifact_folder(root: Path, kind: str) -> Path:
    folder = root / kind / "point_mass_maze"
    if not folder.is_dir():
        raise FbilError(
            f"missing artifact folder {folder}; run fbil from a clone of its repository "
            "(or set FBIL_ARTIFACTS to its artifacts/ folder)"
        )
    return folder


def demo_tasks(spec: str = DEFAULT_TASK, root: str | Path | None = None) -> list[str]:
    """'all' (every committed standard-start demonstration), a task or a comma list of
    tasks, each checked to have a committed demonstration."""
    demos_dir = _artifact_folder(Path(root) if root is not None else artifacts_root(), "demos")
    names = sorted(p.stem for p in demos_dir.glob("*.npz") if not p.stem.endswith("_shifted"))
    tasks = names if spec.strip() == "all" else [t.strip() for t in spec.split(",") if t.strip()]
    for task in tasks or [spec]:
        if task not in names:
            raise FbilError(
                f"no committed demonstration for {task!r}; available: {', '.join(names)}, "
                "all (or several, comma-separated)"
            )
    return tasks


def run_demo(
    task: str = DEFAULT_TASK,
    methods: str = "all",
    episodes: int = 10,
    out: str | Path = DEFAULT_OUT,
    root: str | Path | None = None,
) -> dict[str, Any]:
    from fbil.artifacts import verify
    from fbil.envs.render import plot_imitation_panels
    from fbil.evaluation.evaluate import evaluate
    from fbil.fb.model import FBModel
    from fbil.imitation.demos import Demos
    from fbil.imitators.registry import get_imitator, resolve

    trained = [m for m in resolve(methods).names if not get_imitator(m).needs_model]
    if trained:
        raise FbilError(
            f"fbil demo runs the shipped FB model's methods, not {', '.join(trained)} (trained "
            "on a dataset or another model): use `fbil evaluate ... --data DIR`"
        )
    root = Path(root) if root is not None else artifacts_root()
    if demo_tasks(task, root) != [task]:
        raise FbilError(f"run_demo takes one task, got {task!r}; loop over demo_tasks(...)")
    model_dir, demos_dir = (_artifact_folder(root, kind) for kind in ("models", "demos"))
    for folder in (model_dir, demos_dir):
        verify(folder)  # a missing or altered file stops here, naming it
    demo_path = demos_dir / f"{task}.npz"
    model = FBModel.load(model_dir)
    demos = Demos.load(demo_path)
    result = evaluate(model, demos, methods, k=1, draw=0, episodes=episodes)
    out = Path(out)
    titles = {m: f"{m} ({r.principle}): {100 * r.score:.0f}%" for m, r in result["results"].items()}
    picture = plot_imitation_panels(
        demos.trajectories[0].observation,
        {m: r.trajectory for m, r in result["results"].items()},
        out / f"demo_{task}.png",
        task,
        titles,
    )
    result["picture"] = picture
    return result
