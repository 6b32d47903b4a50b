"""Median wall time from demonstration to policy, per FB-IL method, on these CPUs.

Uses a pre-trained FB model and one demonstration (default: the committed maze model
and the first committed `loop` demo), repeats each method after one warm-up call, and
prints the median next to the paper's GPU timings (Table 8). With `--curve`, also the
imitation score of every gradient method against its optimisation budget (steps of the
z-optimiser), evaluated on the demo's task, as a table and a PNG.

    python benchmarks/time_to_policy.py [--model DIR] [--demos FILE] [--repeats 10]
        [--curve] [--episodes 10] [--json]
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import statistics
from pathlib import Path
from typing import Any

import torch

from fbil.evaluation.evaluate import expert_return, rollout_policies
from fbil.evaluation.paper import PAPER_TIMES
from fbil.fb.model import FBModel
from fbil.imitation import MAIN_METHODS, METHODS, Demos, OptimiserConfig, imitate

ROOT = Path(__file__).resolve().parents[1]
CURVE_STEPS = (0, 10, 25, 50, 100, 200, 400)


def timings(model: Any, demos: Demos, repeats: int) -> dict[str, dict[str, Any]]:
    result = {}
    for method in MAIN_METHODS:
        imitate(model, demos, method)  # warm-up: first-call allocations and lazy imports
        times = [imitate(model, demos, method).seconds for _ in range(repeats)]
        result[method] = {
            "median_seconds": statistics.median(times),
            "max_seconds": max(times),
            "paper_gpu": PAPER_TIMES[method],
        }
    return result


def curve(model: Any, demos: Demos, episodes: int) -> dict[str, dict[int, dict[str, float]]]:
    """Score and final loss of each gradient method against the optimiser's step budget."""
    task = demos.metadata["task"]
    expert = expert_return(demos)
    out: dict[str, dict[int, dict[str, float]]] = {}
    base = OptimiserConfig()
    for method in MAIN_METHODS:
        if not METHODS[method].gradient:
            continue
        policies = [
            imitate(model, demos, method, optimiser=dataclasses.replace(base, steps=s))
            for s in CURVE_STEPS
        ]
        ep = rollout_policies(
            policies, model.metadata["dataset_manifest"]["domain"], task, episodes
        )
        out[method] = {
            s: {
                "score": float(ep.returns[i * episodes : (i + 1) * episodes].mean() / expert),
                "loss_last": float(p.info.get("loss_last", float("nan"))),
                "seconds": p.seconds,
            }
            for i, (s, p) in enumerate(zip(CURVE_STEPS, policies, strict=True))
        }
    return out


def plot_curve(result: dict[str, dict[int, dict[str, float]]], task: str, out: Path) -> None:
    from fbil.envs.render import _pyplot, _save

    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(5, 3.2), dpi=120)
    for method, points in result.items():
        steps = sorted(points)
        ax.plot(steps, [100 * points[s]["score"] for s in steps], "o-", ms=3, label=method)
    ax.axvline(OptimiserConfig().steps, color="gray", ls=":", lw=1)
    ax.set_xscale("symlog", linthresh=10)
    ax.set_xlabel("z-optimiser steps (default dotted)")
    ax.set_ylabel("imitation score (%)")
    ax.set_title(f"maze {task}: quality against optimisation budget", fontsize=9)
    ax.legend(fontsize=7)
    _save(fig, out)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--model", default=str(ROOT / "artifacts/models/point_mass_maze"))
    parser.add_argument("--demos", default=str(ROOT / "artifacts/demos/point_mass_maze/loop.npz"))
    parser.add_argument("--repeats", type=int, default=10)
    parser.add_argument("--curve", action="store_true", help="also score against budget")
    parser.add_argument("--episodes", type=int, default=10, help="--curve: episodes per point")
    parser.add_argument("--plot", default="time_to_policy_curve.png", help="--curve: PNG")
    parser.add_argument("--threads", type=int, default=None)
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    if args.threads:
        torch.set_num_threads(args.threads)
    model = FBModel.load(args.model)
    demos = Demos.load(args.demos).select([0])
    result: dict[str, Any] = {
        "demo_steps": len(demos.trajectories[0]),
        "threads": torch.get_num_threads(),
        "repeats": args.repeats,
        "methods": timings(model, demos, args.repeats),
    }
    if args.curve:
        result["curve"] = curve(model, demos, args.episodes)
        plot_curve(result["curve"], demos.metadata["task"], Path(args.plot))
    if args.json:
        print(json.dumps(result))
        return
    print(
        f"one demonstration of {result['demo_steps']} steps, {result['threads']} threads, "
        f"median of {args.repeats} (after a warm-up call)"
    )
    print(f"{'method':<10}{'principle':<26}{'fbil CPU (s)':>13}{'max (s)':>9}{'paper GPU':>11}")
    for m, r in result["methods"].items():
        print(
            f"{m:<10}{METHODS[m].principle:<26}{r['median_seconds']:>13.4f}"
            f"{r['max_seconds']:>9.4f}{r['paper_gpu']:>11}"
        )
    if args.curve:
        print(f"\nimitation score (%) against z-optimiser steps, {args.episodes} episodes each")
        print(f"{'method':<10}" + "".join(f"{s:>8}" for s in CURVE_STEPS))
        for m, points in result["curve"].items():
            print(f"{m:<10}" + "".join(f"{100 * points[s]['score']:>8.1f}" for s in CURVE_STEPS))
        print(f"plot: {args.plot}")


if __name__ == "__main__":
    main()
