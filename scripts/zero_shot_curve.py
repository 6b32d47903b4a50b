"""Zero-shot learning curve of one FB run: `fbil zero-shot` on each of its snapshots
(`RUN/snapshots/step_N`) and on the run's current model, one JSON row per step, and a
plot of return against updates per task. Steps already in --out are not evaluated again,
so the script can be re-run while the run goes on.

Usage: python scripts/zero_shot_curve.py RUN --data DATASET [--episodes 10]
       [--tasks all] [--out RUN/zero_shot_curve.json] [--plot curve.png] [--threads 1]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import torch

from fbil.checkpoint import atomic_write_text
from fbil.data import load_dataset
from fbil.envs import get_domain
from fbil.errors import FbilError
from fbil.fb.model import FBModel
from fbil.fb.zero_shot import zero_shot


def candidates(run: Path) -> list[tuple[int, Path]]:
    """(updates, folder) of every snapshot and of the run's current model, by step."""
    found = {int(p.name.split("_")[1]): p for p in (run / "snapshots").glob("step_*")}
    config = run / "config.json"
    if (run / "model.safetensors").is_file() and config.is_file():
        # config.json is written with the model: its step count is the model's.
        steps = json.loads(config.read_text()).get("steps")
        if isinstance(steps, int):
            found.setdefault(steps, run)
    if not found:
        raise FbilError(f"no snapshots or model in {run}; pass an `fbil pretrain` output folder")
    return sorted(found.items())


def plot(rows: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    tasks = list(rows[0]["returns"])
    fig, ax = plt.subplots(figsize=(6, 3.6))
    for task in tasks:
        ax.plot([r["step"] for r in rows], [r["returns"][task] for r in rows], "o-", label=task)
    ax.set_xlabel("FB updates")
    ax.set_ylabel("zero-shot return (z_r)")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run", type=Path)
    ap.add_argument("--data", required=True)
    ap.add_argument("--episodes", type=int, default=10)
    ap.add_argument("--tasks", default="all")
    ap.add_argument("--out", type=Path)
    ap.add_argument("--plot", type=Path)
    ap.add_argument("--threads", type=int, default=1)
    args = ap.parse_args(argv)
    torch.set_num_threads(args.threads)
    try:
        out = args.out or args.run / "zero_shot_curve.json"
        found = candidates(args.run)
        saved = json.loads(out.read_text()) if out.is_file() else {"run": str(args.run)}
        if saved.get("run") != str(args.run):  # resume only the same run's curve
            raise FbilError(
                f"{out} holds the curve of another run ({saved.get('run')}); pass another "
                "--out, or delete it to start this run's curve"
            )
        rows = saved.get("rows", [])
        done = {r["step"] for r in rows}
        todo = [(s, p) for s, p in found if s not in done]
        dataset = load_dataset(args.data) if todo else None
        if dataset is not None:
            tasks = (
                get_domain(dataset.domain).task_names if args.tasks == "all"
                else args.tasks.split(",")
            )  # fmt: skip
        for step, folder in todo:
            assert dataset is not None
            res = zero_shot(FBModel.load(folder), dataset, tasks, args.episodes)
            returns = {t: round(v["return_mean"], 1) for t, v in res["tasks"].items()}
            rows.append({"step": step, "returns": returns, "episodes": args.episodes})
            rows.sort(key=lambda r: r["step"])
            doc = {"run": str(args.run), "data": str(args.data), "rows": rows}
            atomic_write_text(out, json.dumps(doc, indent=1) + "\n")
            print(step, returns, flush=True)
        if args.plot and rows:
            plot(rows, args.plot)
    except FbilError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
