"""Write experts.json (expert returns over the committed standard-start demos, next to the
paper's Table 5 expert row) and the manifest of a maze demos folder.

    python scripts/experts_table.py artifacts/demos/point_mass_maze runs/experts/point_mass_maze
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from fbil.artifacts import write_manifest
from fbil.checkpoint import atomic_write_text
from fbil.evaluation.paper import PAPER_RETURNS
from fbil.fb.train import git_commit
from fbil.imitation import Demos


def main(demos_dir: str, experts_dir: str) -> None:
    paper = PAPER_RETURNS["point_mass_maze"]["expert"]
    tasks, wall, steps = {}, 0.0, {}
    for task in sorted(paper):
        demos = Demos.load(Path(demos_dir) / f"{task}.npz")
        meta = json.loads((Path(experts_dir) / task / "expert.json").read_text())
        log = (Path(experts_dir) / task / "train_log.csv").read_text().splitlines()
        wall += float(log[-1].split(",")[-1])
        steps[task] = meta["steps"]
        m = demos.metadata
        tasks[task] = {
            "return_mean": round(m["return_mean"], 1),
            "return_std": round(m["return_std"], 1),
            "episodes": len(demos),
            "paper_return": paper[task],
            "ratio_to_paper": round(m["return_mean"] / paper[task], 3),
            "actor_step": meta.get("best_step"),
        }
        shifted = Path(demos_dir) / f"{task}_shifted.npz"
        if shifted.is_file():
            tasks[task]["shifted_return_mean"] = round(
                Demos.load(shifted).metadata["return_mean"], 1
            )
    atomic_write_text(
        Path(demos_dir) / "experts.json", json.dumps({"tasks": tasks}, indent=2) + "\n"
    )
    write_manifest(
        demos_dir,
        "scripts/maze_experts.sh datasets/point_mass_maze/rnd_uniform runs/experts/point_mass_maze "
        "artifacts/demos/point_mass_maze 30000 1 (offline TD3, n-step 10, 30 000 updates per task; "
        "20 standard-start demos with --seed 0, 10 shifted-start demos); then "
        "python scripts/experts_table.py artifacts/demos/point_mass_maze "
        "runs/experts/point_mass_maze",
        0,
        round(wall, 1),
        git_commit(),
        {
            "updates": steps,
            "data": "datasets/point_mass_maze/rnd_uniform",
            "note": "tasks with more than 30 000 updates were continued with `fbil expert ... "
            "--resume --steps N --set nstep=10` and their demos recorded again",
        },
    )


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
