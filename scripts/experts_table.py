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

import argparse
import json
import sys
from pathlib import Path
from typing import Any, NoReturn

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
    data: set[str] = set()
    while (folder / "expert.json").is_file():
        meta = json.loads((folder / "expert.json").read_text())
        first = first or meta
        chain.append(
            {"folder": folder.name, "mode": meta["mode"], "steps": meta["steps"],
             "command": meta.get("command", "")}
        )  # fmt: skip
        wall += _wall(folder)
        words = " ".join(meta.get("commands") or [meta.get("command", "")]).split()
        data.update(words[i + 1] for i, w in enumerate(words[:-1]) if w == "--data")
        if "--init" not in words:
            break
        folder = Path(words[words.index("--init") + 1])
    kinds = " <- ".join(f"{c['mode']} TD3 ({c['steps']} steps, {c['folder']})" for c in chain)
    return {
        "expert": kinds,
        "actor_step": first.get("best_step") if first else None,
        "chain": chain,
        "wall_seconds": round(wall, 1),
        "data": sorted(data),  # the datasets of the chain's commands (`--data`)
    }


MAZE_COMMAND = (
    "scripts/maze_experts.sh DATA runs/experts/point_mass_maze DEMOS 30000 1 (offline TD3, "
    "n-step 10; with ONLINE_STEPS=N each offline expert is then fine-tuned online for N "
    "steps and the demos come from it: 20 standard-start demos with --seed 0, 10 "
    "shifted-start demos); then python scripts/experts_table.py "
    "artifacts/demos/point_mass_maze runs/experts/point_mass_maze"
)


def _command(domain: str, demos_dir: str, experts_dir: str) -> str:
    """The command that made the table: the maze's own script, or scripts/experts.sh
    (walker_experts.sh is experts.sh walker) for a locomotion domain."""
    if domain == "point_mass_maze":
        return MAZE_COMMAND
    return (
        f"scripts/experts.sh {domain} {experts_dir} {demos_dir} 1 (online TD3, n-step 3, "
        "TASKS/PRECISION/STEPS_<task>/DATA per expert as recorded in each chain's command; "
        "20 standard-start demos with --seed 0, 10 shifted-start demos); then python "
        f"scripts/experts_table.py {demos_dir} {experts_dir}"
    )


def _data(made: dict[str, dict[str, Any]]) -> str:
    """The datasets the experts trained on (`--data` in their chains' commands)."""
    used = sorted({path for task in made.values() for path in task["data"]})
    return ", ".join(used) or "none (online TD3 in the environment)"


def _fail(message: str) -> NoReturn:
    print(f"error: {message}", file=sys.stderr)
    raise SystemExit(2)


def main(demos_dir: str, experts_dir: str) -> None:
    domain = Path(demos_dir).name
    if domain not in PAPER_RETURNS:
        known = ", ".join(sorted(PAPER_RETURNS))
        _fail(f"{demos_dir}: the folder's name must be a domain ({known})")
    if not Path(experts_dir).is_dir():
        _fail(f"{experts_dir}: no such experts folder")
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
            _fail(f"no expert for {task} in {experts_dir} and none in {table}")
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
        _command(domain, demos_dir, experts_dir),
        0,
        round(sum(m["wall_seconds"] for m in made_here.values()), 1),
        git_commit(),
        {
            "made_in_this_run": made_here,
            "kept_from_the_previous_table": kept,
            "previous_manifests": history,
            # a run that kept every task keeps the table's data as recorded before
            "data": _data(made_here) if made_here else before.get("data", _data({})),
        },
    )


if __name__ == "__main__":
    parser = argparse.ArgumentParser(
        description="experts.json and the manifest of a demos folder, from its experts"
    )
    parser.add_argument("demos_dir", help="artifacts/demos/DOMAIN (its name is the domain)")
    parser.add_argument("experts_dir", help="the experts' folders, e.g. runs/experts_online/DOMAIN")
    args = parser.parse_args()
    main(args.demos_dir, args.experts_dir)
