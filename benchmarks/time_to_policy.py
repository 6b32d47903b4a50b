"""Median wall time from demonstration to policy, per FB-IL method, on these CPUs.

Uses a pre-trained FB model and one demonstration (default: the committed maze model
and the first committed `loop` demo), repeats each method after one warm-up call, and
prints the median next to the paper's GPU timings (Table 8). With `--curve`, also the
imitation score of every gradient method against its optimisation budget (steps of the
z-optimiser), evaluated on the demo's task, as a table and a PNG.

With `--baselines NAMES --data DIR`, the same run also times the offline-IL baselines on
the same demo and machine: each is fitted `--baseline-repeats` times at each of the small
`--scales` of its `--budget` (all its gradient steps times the scale), and a line through
the medians, seconds = fixed + per_scale * scale, projects its time at the full budget
(scale 1). Training a baseline at its full budget three times would take hours; its time
is linear in its steps, plus fixed work (statistics, OT rewards) that the line's intercept
keeps. The ratio to the FB-IL methods' median is then measured on one machine in one run.

    python benchmarks/time_to_policy.py [--model DIR] [--demos FILE] [--repeats 10]
        [--curve] [--episodes 10] [--json]
        [--baselines bc,dwbc,... --data DIR --scales 0.01,0.02 --baseline-repeats 3]
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import statistics
import sys
from pathlib import Path
from typing import Any

import torch

from fbil.artifacts import machine
from fbil.data import load_dataset
from fbil.evaluation.evaluate import expert_return, rollout_policies
from fbil.evaluation.paper import PAPER_TIMES
from fbil.fb.model import FBModel
from fbil.imitation import MAIN_METHODS, METHODS, Demos, OptimiserConfig, imitate
from fbil.imitators import FitContext, get_imitator, resolve
from fbil.imitators.budgets import resolve_auto, scaled_spec

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


def line_through(xs: list[float], ys: list[float]) -> tuple[float, float]:
    """Least-squares (intercept, slope) of ys against xs (two or more distinct xs)."""
    n = len(xs)
    mx, my = sum(xs) / n, sum(ys) / n
    sxx = sum((x - mx) ** 2 for x in xs)
    if n < 2 or sxx == 0:
        raise ValueError("a line needs two or more distinct scales")
    slope = sum((x - mx) * (y - my) for x, y in zip(xs, ys, strict=True)) / sxx
    return my - slope * mx, slope


def baseline_timings(
    names: list[str], demos: Demos, dataset: Any, budget: str, scales: list[float], repeats: int
) -> dict[str, dict[str, Any]]:
    """Per baseline: the median fit seconds at each scale of `budget`, and the line's
    projection to the full budget (see the module's docstring)."""
    result = {}
    for name in names:
        imitator = get_imitator(name)
        if not imitator.budgets:
            continue  # nothing to train (goal_td3 uses a pre-trained model)
        spec = resolve_auto(budget, name, demos.metadata.get("domain"))
        medians = []
        for scale in scales:
            context = FitContext(
                dataset=dataset, budget=scaled_spec(spec, scale), threads=torch.get_num_threads()
            )
            times = [imitator.fit(demos, context).seconds for _ in range(repeats)]
            medians.append(statistics.median(times))
        fixed, per_scale = line_through(scales, medians)
        result[name] = {
            "budget": spec,
            "median_seconds": dict(zip(map(str, scales), medians, strict=True)),
            "fixed_seconds": fixed,
            "projected_seconds": fixed + per_scale,
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
    parser.add_argument("--baselines", default="", help="offline-IL methods to time too")
    parser.add_argument("--data", default=None, help="--baselines: the unsupervised dataset")
    parser.add_argument(
        "--budget",
        default="auto",
        help="--baselines: the budget projected (auto: each method's measured one on the domain)",
    )
    parser.add_argument("--scales", default="0.01,0.02", help="--baselines: scales fitted")
    parser.add_argument("--baseline-repeats", type=int, default=3)
    args = parser.parse_args()
    names = resolve(args.baselines).names if args.baselines else []
    if names and not args.data:
        parser.error("--baselines needs --data (the unsupervised dataset they train on)")
    if args.threads:
        torch.set_num_threads(args.threads)
    model = FBModel.load(args.model)
    demos = Demos.load(args.demos).select([0])
    result: dict[str, Any] = {
        "command": " ".join(["python benchmarks/time_to_policy.py", *sys.argv[1:]]),
        "domain": demos.metadata.get("domain"),
        "demos": args.demos,
        "demo_steps": len(demos.trajectories[0]),
        "baseline_repeats": args.baseline_repeats,
        "threads": torch.get_num_threads(),
        "repeats": args.repeats,
        "machine": machine(),
        "methods": timings(model, demos, args.repeats),
    }
    if names:
        scales = [float(x) for x in args.scales.split(",")]
        dataset = load_dataset(args.data, domain=demos.metadata.get("domain"))
        result["baselines"] = baseline_timings(
            names, demos, dataset, args.budget, scales, args.baseline_repeats
        )
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
    if names:
        fb_median = statistics.median(r["median_seconds"] for r in result["methods"].values())
        print(
            f"\nbaselines, median of {args.baseline_repeats} fits per scale, projected to "
            f"{args.budget} (FB-IL median {fb_median:.4f} s)"
        )
        print(
            f"{'method':<10}"
            + "".join(f"{'@' + s:>10}" for s in args.scales.split(","))
            + f"{'fixed (s)':>11}{'projected (s)':>15}{'x FB-IL':>10}"
        )
        for m, r in result["baselines"].items():
            print(
                f"{m:<10}"
                + "".join(f"{v:>10.2f}" for v in r["median_seconds"].values())
                + f"{r['fixed_seconds']:>11.2f}{r['projected_seconds']:>15.1f}"
                + f"{r['projected_seconds'] / fb_median:>10.0f}"
            )
    if args.curve:
        print(f"\nimitation score (%) against z-optimiser steps, {args.episodes} episodes each")
        print(f"{'method':<10}" + "".join(f"{s:>8}" for s in CURVE_STEPS))
        for m, points in result["curve"].items():
            print(f"{m:<10}" + "".join(f"{100 * points[s]['score']:>8.1f}" for s in CURVE_STEPS))
        print(f"plot: {args.plot}")


if __name__ == "__main__":
    main()
