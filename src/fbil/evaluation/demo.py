"""`fbil demo`: the whole job on a shipped FB model, in about a minute.

Loads a domain's committed `cpu` FB model and one of its committed expert demonstrations
(both checked against their manifests), imitates it with every FB-IL method, evaluates
each policy with the batched engine, prints a table and draws the demonstration against
each method's rollout with the domain's own picture (the maze: paths over its walls;
locomotion: rows of frames)."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np

from fbil.errors import FbilError

DEFAULT_DOMAIN = "point_mass_maze"
DEFAULT_OUT = "runs/demo"  # runs/ is gitignored: the demo leaves no untracked files


def artifacts_root() -> Path:
    """FBIL_ARTIFACTS, else the checkout's artifacts/ (fbil is installed from a clone)."""
    env = os.environ.get("FBIL_ARTIFACTS")
    return Path(env) if env else Path(__file__).resolve().parents[3] / "artifacts"


def _artifact_folder(root: Path, kind: str, domain: str) -> Path:
    folder = root / kind / domain
    if folder.is_dir():
        return folder
    if not (root / kind).is_dir():
        raise FbilError(
            f"missing artifact folder {folder}; run fbil from a clone of its repository "
            "(or set FBIL_ARTIFACTS to its artifacts/ folder)"
        )
    have = sorted(p.name for p in (root / kind).iterdir() if (p / "manifest.json").is_file())
    raise FbilError(
        f"no committed {kind} for {domain} yet; fbil demo runs on a domain with a shipped "
        f"model and demos: --domain {' or '.join(have) or '(none committed)'}"
    )


def demo_tasks(
    spec: str | None = None, root: str | Path | None = None, domain: str = DEFAULT_DOMAIN
) -> list[str]:
    """'all' (every committed standard-start demonstration), a task or a comma list of
    tasks, each checked to have a committed demonstration; None: the domain's demo task
    (`DomainHooks.demo_task`), else its first committed demonstration."""
    from fbil.envs import get_domain

    hooks = get_domain(domain).hooks  # an unknown domain stops here, naming the known ones
    root = Path(root) if root is not None else artifacts_root()
    demos_dir = _artifact_folder(root, "demos", domain)
    names = sorted(p.stem for p in demos_dir.glob("*.npz") if not p.stem.endswith("_shifted"))
    if spec is None:
        spec = hooks.demo_task if hooks.demo_task in names else (names or [""])[0]
    tasks = names if spec.strip() == "all" else [t.strip() for t in spec.split(",") if t.strip()]
    for task in tasks or [spec]:
        if task not in names:
            raise FbilError(
                f"no committed {domain} demonstration for {task!r}; available: "
                f"{', '.join(names)}, all (or several, comma-separated)"
            )
    return tasks


def run_demo(
    task: str,
    methods: str = "all",
    episodes: int = 10,
    out: str | Path = DEFAULT_OUT,
    root: str | Path | None = None,
    domain: str = DEFAULT_DOMAIN,
) -> dict[str, Any]:
    from fbil.artifacts import verify
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
    if demo_tasks(task, root, domain) != [task]:
        raise FbilError(f"run_demo takes one task, got {task!r}; loop over demo_tasks(...)")
    model_dir, demos_dir = (_artifact_folder(root, kind, domain) for kind in ("models", "demos"))
    for folder in (model_dir, demos_dir):
        verify(folder)  # a missing or altered file stops here, naming it
    model = FBModel.load(model_dir)
    demos = Demos.load(demos_dir / f"{task}.npz")
    result = evaluate(model, demos, methods, k=1, draw=0, episodes=episodes)
    picture = _picture(domain, task, demos, result["results"], Path(out) / f"demo_{task}.png")
    result["picture"] = picture
    return result


def _picture(domain: str, task: str, demos: Any, results: dict[str, Any], out: Path) -> Path | None:
    """The demonstration against each method's first evaluation episode, drawn by the
    domain's picture hook from what it keeps of a rollout (as the report's pictures)."""
    from fbil.envs import get_domain
    from fbil.envs.hooks import ImitationPicture

    pictures = get_domain(domain).hooks.pictures
    if pictures is None:
        return None
    rollouts = {}
    for method, r in results.items():
        kept = pictures.keep(r.trajectory, None)
        if kept is not None:
            rollouts[method] = np.asarray(kept)
    titles = {m: f"{m}: {100 * r.score:.0f}%" for m, r in results.items()}
    demo = demos.trajectories[0]
    picture = ImitationPicture(demo.observation, demo.physics, rollouts, out, task, titles)
    return pictures.imitation(picture)
