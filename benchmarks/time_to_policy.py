"""Median wall time from demonstration to policy, per FB-IL method, on these CPUs.

Uses a pre-trained FB model and one demonstration (default: the committed maze model
and the first committed `loop` demo), repeats each method, and prints the median next
to the paper's GPU timings (Table 8).

    python benchmarks/time_to_policy.py [--model DIR] [--demos FILE] [--repeats 5] [--json]
"""

from __future__ import annotations

import argparse
import json
import statistics
from pathlib import Path

import torch

from fbil.fb.model import FBModel
from fbil.imitation import MAIN_METHODS, METHODS, Demos, imitate

ROOT = Path(__file__).resolve().parents[1]
# Paper Table 8 (GPU), seconds.
PAPER_SECONDS = {
    "erfb": 5,
    "rerfb": 5,
    "goalfb": 5,
    "bcfb": 60,
    "fmfb": 180,
    "dmfb": 180,
    "bbellfb": 240,
    "fblossfb": 240,
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--model", default=str(ROOT / "artifacts/models/point_mass_maze"))
    parser.add_argument("--demos", default=str(ROOT / "artifacts/demos/point_mass_maze/loop.npz"))
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--threads", type=int, default=None)
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    if args.threads:
        torch.set_num_threads(args.threads)
    model = FBModel.load(args.model)
    demos = Demos.load(args.demos).select([0])
    result = {}
    for method in MAIN_METHODS:
        times = [imitate(model, demos, method).seconds for _ in range(args.repeats)]
        result[method] = {
            "median_seconds": statistics.median(times),
            "paper_gpu_seconds": PAPER_SECONDS[method],
        }
    if args.json:
        print(json.dumps({"demo_steps": len(demos.trajectories[0]), "methods": result}))
        return
    print(
        f"one demonstration of {len(demos.trajectories[0])} steps, "
        f"{torch.get_num_threads()} threads, median of {args.repeats}"
    )
    print(f"{'method':<10}{'principle':<26}{'fbil CPU (s)':>13}{'paper GPU (s)':>15}")
    for m, r in result.items():
        print(
            f"{m:<10}{METHODS[m].principle:<26}{r['median_seconds']:>13.3f}"
            f"{'< ' if r['paper_gpu_seconds'] == 5 else '~ '}{r['paper_gpu_seconds']:>11}"
        )


if __name__ == "__main__":
    main()
