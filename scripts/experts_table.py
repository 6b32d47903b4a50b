"""Write experts.json (expert returns over the committed standard-start demos, next to the
paper's expert row of Tables 5-7) and the manifest of a demos folder (its name is the
domain); tasks without a demo file yet are left out.

    python scripts/experts_table.py artifacts/demos/point_mass_maze runs/experts/point_mass_maze
    python scripts/experts_table.py artifacts/demos/walker runs/experts_online/walker

Each task's expert is the folder of EXPERTS named in its demos' `source`, followed back
through `--init` to the expert it was fine-tuned from; a task whose expert folder is not
here keeps its entry of the existing experts.json (its demos were made earlier, on another
machine), so re-running after improving some experts leaves the others as committed.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

from fbil.artifacts import write_manifest
from fbil.checkpoint import atomic_write_text
from fbil.evaluation.paper import PAPER_RETURNS
from fbil.fb.train import git_commit
from fbil.imitation import Demos


def _wall(folder: Path) -> float:
    rows = (folder / "train_log.csv").read_text().splitlines()
    return float(rows[-1].split(",")[-1])


def _provenance(experts: Path, source: str) -> dict[str, Any] | None:
    """How the expert named in a demo file's `source` was made, following `--init` back
    to the expert it started from; None when its folder is not in `experts`."""
    folder = experts / source.removeprefix("TD3 expert ")
    if not (folder / "expert.json").is_file():
        return None
    chain, wall, first = [], 0.0, None
    while (folder / "expert.json").is_file():
        meta = json.loads((folder / "expert.json").read_text())
        first = first or meta
        chain.append(
            {"folder": folder.name, "mode": meta["mode"], "steps": meta["steps"],
             "command": meta.get("command", "")}
        )  # fmt: skip
        wall += _wall(folder)
        words = " ".join(meta.get("commands") or [meta.get("command", "")]).split()
        if "--init" not in words:
            break
        folder = Path(words[words.index("--init") + 1])
    kinds = " <- ".join(f"{c['mode']} TD3 ({c['steps']} steps, {c['folder']})" for c in chain)
    return {
        "expert": kinds,
        "actor_step": first.get("best_step") if first else None,
        "chain": chain,
        "wall_seconds": round(wall, 1),
    }


COMMANDS = {
    "point_mass_maze": (
        "scripts/maze_experts.sh DATA runs/experts/point_mass_maze DEMOS 30000 1 (offline TD3, "
        "n-step 10; with ONLINE_STEPS=N each offline expert is then fine-tuned online for N "
        "steps and the demos come from it: 20 standard-start demos with --seed 0, 10 "
        "shifted-start demos); then python scripts/experts_table.py "
        "artifacts/demos/point_mass_maze runs/experts/point_mass_maze"
    ),
    "walker": (
        "scripts/walker_experts.sh runs/experts_online/walker artifacts/demos/walker 1 (online "
        "TD3, n-step 3, TASKS/PRECISION/STEPS_<task> per expert as recorded in each chain's "
        "command; 20 standard-start demos with --seed 0, 10 shifted-start demos); then python "
        "scripts/experts_table.py artifacts/demos/walker runs/experts_online/walker"
    ),
}
DATA = {
    "point_mass_maze": "datasets/point_mass_maze/rnd_uniform (408 episodes)",
    "walker": "none (online TD3 in the environment)",
}


def main(demos_dir: str, experts_dir: str) -> None:
    domain = Path(demos_dir).name
    paper = PAPER_RETURNS[domain]["expert"]
    table = Path(demos_dir) / "experts.json"
    previous = json.loads(table.read_text())["tasks"] if table.is_file() else {}
    tasks, made_here = {}, {}
    for task in sorted(paper):
        if not (Path(demos_dir) / f"{task}.npz").is_file():
            continue
        demos = Demos.load(Path(demos_dir) / f"{task}.npz")
        made = _provenance(Path(experts_dir), demos.metadata.get("source", ""))
        if made is None and task in previous:
            tasks[task] = previous[task]
            continue
        if made is None:
            raise SystemExit(f"no expert for {task} in {experts_dir} and none in {table}")
        m = demos.metadata
        tasks[task] = {
            "return_mean": round(m["return_mean"], 1),
            "return_std": round(m["return_std"], 1),
            "episodes": len(demos),
            "paper_return": paper[task],
            "ratio_to_paper": round(m["return_mean"] / paper[task], 3),
            "actor_step": made["actor_step"],
            "expert": made["expert"],
        }
        shifted = Path(demos_dir) / f"{task}_shifted.npz"
        if shifted.is_file():
            tasks[task]["shifted_return_mean"] = round(
                Demos.load(shifted).metadata["return_mean"], 1
            )
        made_here[task] = made
    atomic_write_text(table, json.dumps({"tasks": tasks}, indent=2) + "\n")
    kept = sorted(set(tasks) - set(made_here))
    manifest = Path(demos_dir) / "manifest.json"
    before = json.loads(manifest.read_text()) if manifest.is_file() else {}
    history = before.get("previous_manifests", [])
    if kept and before:  # the kept tasks' provenance is the earlier manifest's
        history.append(
            {k: v for k, v in before.items() if k not in ("sha256", "previous_manifests")}
        )
    write_manifest(
        demos_dir,
        COMMANDS[domain],
        0,
        round(sum(m["wall_seconds"] for m in made_here.values()), 1),
        git_commit(),
        {
            "made_in_this_run": made_here,
            "kept_from_the_previous_table": kept,
            "previous_manifests": history,
            "data": DATA[domain],
        },
    )


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
