"""How close each FB-IL method's z comes to the z's an FB model is trained on (seconds, no
rollout).

Training draws z as a Gaussian direction, as B(s') of a dataset state, or (z_from_traj_ratio)
as the mean of B over 16 states of one trajectory segment. For each task's demo (draw 0, K =
1) and each method, this prints the largest cosine between the method's z and B(s') of
--states random dataset states, and between it and --segments random segment means drawn
as in training. A z whose nearest training z is far is one F and the actor have learned
little about; Gaussian directions, nearly orthogonal to everything in high dimension, do
not fill that gap.

Usage: python scripts/z_coverage.py MODEL --data DIR --demos DIR [--tasks all]
           [--methods erfb,bcfb,dmfb,bbellfb,fblossfb] [--states 50000] [--segments 20000]
           [--json OUT]
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
from pathlib import Path

import torch

from fbil.checkpoint import atomic_write_text
from fbil.data import Dataset, load_dataset
from fbil.errors import FbilError
from fbil.evaluation.benchmark import load_task_demos
from fbil.evaluation.evaluate import demo_draw
from fbil.fb.model import FBModel
from fbil.fb.train import TRAJ_Z_STATES, episode_last_transition, segment_states
from fbil.imitation import METHODS, imitate


@torch.no_grad()
def training_directions(
    model: FBModel, data: Dataset, states: int, segments: int, seed: int = 0
) -> tuple[torch.Tensor, torch.Tensor]:
    """Unit B(s') of random next states, and unit segment means drawn as in training."""
    gen = torch.Generator().manual_seed(seed)
    nxt, obs = torch.from_numpy(data.next_index), torch.from_numpy(data.observation)
    b = model.backward(obs[nxt[torch.randint(0, len(nxt), (states,), generator=gen)]])
    at = segment_states(nxt, episode_last_transition(nxt), segments, gen)
    means = model.backward(obs[at].reshape(-1, obs.shape[1])).reshape(segments, TRAJ_Z_STATES, -1)
    unit = torch.nn.functional.normalize
    return unit(b, dim=-1), unit(means.mean(1), dim=-1)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("model")
    p.add_argument("--data", required=True)
    p.add_argument("--demos", required=True)
    p.add_argument("--tasks", default="all")
    p.add_argument("--methods", default="erfb,bcfb,dmfb,bbellfb,fblossfb")
    p.add_argument("--states", type=int, default=50_000)
    p.add_argument("--segments", type=int, default=20_000)
    p.add_argument("--json", default=None)
    args = p.parse_args(argv)
    torch.set_num_threads(1)
    try:
        methods = [m.strip() for m in args.methods.split(",") if m.strip()]
        unknown = [m for m in methods if m not in METHODS or m == "goalfb"]
        if unknown:
            raise FbilError(f"methods with one z only (not goalfb): {', '.join(unknown)}")
        model = FBModel.load(args.model)
        demos = load_task_demos(args.demos, args.tasks, model.domain)
        b, means = training_directions(model, load_dataset(args.data), args.states, args.segments)
    except FbilError as exc:
        print(f"z_coverage: error: {exc}", file=sys.stderr)
        return 2
    rows: dict[str, dict[str, list[float]]] = {}
    for d in demos.values():
        group = demo_draw(d, 1, 0)
        for m in methods:
            z = torch.nn.functional.normalize(imitate(model, group, m).z.flatten(), dim=0)
            row = rows.setdefault(m, {"b": [], "traj": []})
            row["b"].append(float((b @ z).max()))
            row["traj"].append(float((means @ z).max()))
    for m, row in rows.items():
        print(
            f"{m}: nearest B(s') cos {statistics.mean(row['b']):.3f}, nearest segment mean "
            f"cos {statistics.mean(row['traj']):.3f} (per task: "
            + ", ".join(f"{c:.2f}" for c in row["traj"])
            + ")"
        )
    if args.json:
        out = {"model": args.model, "tasks": list(demos), "methods": rows}
        atomic_write_text(Path(args.json), json.dumps(out, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
