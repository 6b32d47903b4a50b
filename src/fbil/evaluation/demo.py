"""`fbil demo`: the whole job on the shipped maze model, in about a minute.

Loads the committed `cpu` maze FB model and one committed expert demonstration (both
checked against their manifests), imitates it with every FB-IL method, evaluates each
policy with the batched engine, prints a table and draws the demonstration against each
method's rollout over the maze walls."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from fbil.artifacts import verify
from fbil.errors import FbilError
from fbil.evaluation.evaluate import evaluate

DEFAULT_TASK = "loop"  # a path to follow, where the principles visibly differ


def artifacts_root() -> Path:
    """FBIL_ARTIFACTS, else the checkout's artifacts/ (fbil is installed from a clone)."""
    env = os.environ.get("FBIL_ARTIFACTS")
    return Path(env) if env else Path(__file__).resolve().parents[3] / "artifacts"


def run_demo(
    task: str = DEFAULT_TASK,
    methods: str = "all",
    episodes: int = 10,
    out: str | Path = "fbil-demo",
    root: str | Path | None = None,
) -> dict[str, Any]:
    from fbil.envs.render import plot_imitation_panels
    from fbil.fb.model import FBModel
    from fbil.imitation.demos import Demos

    root = Path(root) if root is not None else artifacts_root()
    model_dir = root / "models" / "point_mass_maze"
    demos_dir = root / "demos" / "point_mass_maze"
    for folder in (model_dir, demos_dir):
        if not folder.is_dir():
            raise FbilError(
                f"missing artifact folder {folder}; run fbil from a clone of its repository "
                "(or set FBIL_ARTIFACTS to its artifacts/ folder)"
            )
        verify(folder)  # a missing or altered file stops here, naming it
    demo_path = demos_dir / f"{task}.npz"
    if not demo_path.is_file():
        names = sorted(p.stem for p in demos_dir.glob("*.npz") if not p.stem.endswith("_shifted"))
        raise FbilError(f"no committed demonstration for {task!r}; available: {', '.join(names)}")
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
