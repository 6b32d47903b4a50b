"""Score against training budget (issue #22 item 2): a baseline run at scaled budgets
(`cpu@0.25`, `cpu@0.5`, `cpu`, `cpu@2`, ...) on a few tasks, as points of median time to
policy and mean imitation score, next to the paper's score on the same tasks.

`scripts/budget_curve.py` runs the benchmark jobs and writes `budget_curve.json` (what
`build_curve` returns) and `budget_curve.png`; `fbil report` adds the figure and a table
when a `budget_curve.json` sits next to the results file or is passed with
`--budget-curve`.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from fbil.errors import FbilError
from fbil.evaluation.paper import PAPER_RETURNS, PAPER_SCORES
from fbil.imitators.budgets import STEP_FIELD

CURVE_FILE = "budget_curve.json"
FIGURE_FILE = "budget_curve.png"


def paper_level(domain: str, method: str, tasks: Sequence[str]) -> float | None:
    """The paper's imitation score (%) of `method` averaged over `tasks` (its Tables 5-7
    returns over its expert's); None when the paper has no row for it."""
    returns = PAPER_RETURNS.get(domain, {})
    ours, expert = returns.get(method, {}), returns.get("expert", {})
    if not tasks or any(t not in ours or t not in expert for t in tasks):
        return None
    return float(np.mean([100 * ours[t] / expert[t] for t in tasks]))


def step_counts(config: dict[str, Any], prefix: str = "") -> dict[str, int]:
    """Every gradient-step count of a recorded budget configuration, by its path
    ('td3', 'discriminator'; '' for a top-level `steps`)."""
    found: dict[str, int] = {}
    for key, value in config.items():
        if isinstance(value, dict):
            found.update(step_counts(value, f"{prefix}{key}."))
        elif key == STEP_FIELD and isinstance(value, int):
            found[prefix.rstrip(".")] = value
    return found


def curve_point(scale: float, spec: str, summary: dict[str, Any], config: Any) -> dict[str, Any]:
    """One (method, scale) point from `report.summarise`'s summary of the method's jobs at
    that budget and one of its results lines' recorded configuration."""
    return {
        "scale": scale,
        "budget": spec,
        "steps": step_counts(config) if isinstance(config, dict) else {},
        "seconds_median": summary["seconds_median"],
        "score_pct": 100 * summary["score"],
        "ci95_pct": 100 * summary["ci95"],
        "draws": summary["draws"],
        "jobs": summary["jobs"],
        "task_scores_pct": {t: 100 * r["score"] for t, r in summary["tasks"].items()},
    }


def build_curve(
    domain: str, tasks: Sequence[str], settings: dict[str, Any], points: dict[str, list[Any]]
) -> dict[str, Any]:
    """The curve: `settings` (budget, draws, episodes, k, ...) and, per method, its points
    in scale order (`points[method]`: `curve_point`s) with the paper's level."""
    methods = {
        m: {
            "paper_score_pct": paper_level(domain, m, tasks),
            "paper_domain_score_pct": PAPER_SCORES.get(domain, {}).get(m),
            "points": sorted(found, key=lambda p: p["scale"]),
        }
        for m, found in points.items()
    }
    for entry in methods.values():
        entry["tasks"] = list(tasks)
    return {"domain": domain, "tasks": list(tasks), **settings, "methods": methods}


MERGED_SETTINGS = ("budget", "draws", "episodes", "k")


def merge_curves(old: dict[str, Any], new: dict[str, Any]) -> dict[str, Any]:
    """`new` with the methods of `old` it does not have: a method's entry in `new` replaces
    its entry in `old`, and each entry keeps the tasks it was measured on (an old entry
    without them was measured on `old`'s tasks). The two must share the domain and the
    settings that make points comparable (budget, draws, episodes, K)."""
    if old.get("domain") != new.get("domain"):
        raise FbilError(
            f"cannot merge a {new.get('domain')} budget curve into one of {old.get('domain')}"
        )
    for key in MERGED_SETTINGS:
        if key in old and old[key] != new.get(key):
            raise FbilError(
                f"cannot merge budget curves with another {key} ({new.get(key)!r} against "
                f"{old[key]!r}); run the curve with the merged one's {key}"
            )
    kept = {
        m: {**e, "tasks": list(e.get("tasks", old.get("tasks", [])))}
        for m, e in old["methods"].items()
        if m not in new["methods"]
    }
    methods = {**kept, **new["methods"]}
    tasks = list(dict.fromkeys(t for e in methods.values() for t in e["tasks"]))
    results = list(dict.fromkeys([*old.get("results", []), *new.get("results", [])]))
    scales = sorted({*old.get("scales", []), *new.get("scales", [])})
    return {**new, "tasks": tasks, "scales": scales, "results": results, "methods": methods}


def write_curve(curve: dict[str, Any], out_dir: str | Path) -> tuple[Path, Path]:
    """OUT/budget_curve.json and OUT/budget_curve.png."""
    from fbil.checkpoint import atomic_write_text

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    path = out_dir / CURVE_FILE
    atomic_write_text(path, json.dumps(curve, indent=1) + "\n")
    return path, curve_figure(curve, out_dir / FIGURE_FILE)


def read_curve(path: str | Path) -> dict[str, Any]:
    try:
        curve = json.loads(Path(path).read_text())
    except (OSError, ValueError) as exc:
        raise FbilError(f"cannot read the budget curve {path}: {exc}") from None
    if not isinstance(curve, dict) or not isinstance(curve.get("methods"), dict):
        raise FbilError(f"{path} is not a budget curve (no 'methods'; see scripts/budget_curve.py)")
    return curve


def find_curve(results: Sequence[str | Path], explicit: str | Path | None) -> Path | None:
    """The budget curve for a report: `explicit`, else a `budget_curve.json` next to one
    of the results files, else None."""
    if explicit is not None:
        return Path(explicit)
    found = [Path(f).parent / CURVE_FILE for f in results]
    return next((p for p in found if p.is_file()), None)


def curve_figure(curve: dict[str, Any], out: Path) -> Path:
    """One panel per method (shared score axis): score against median time to policy (log
    x), each point marked with its scale, the paper's score on the same tasks dashed."""
    from fbil.envs.render import _pyplot, _save

    plt = _pyplot()
    methods = list(curve["methods"].items())
    cols = min(4, max(1, len(methods)))
    rows = math.ceil(len(methods) / cols)
    fig, axes = plt.subplots(
        rows, cols, figsize=(2.6 * cols + 0.6, 2.3 * rows + 0.5), dpi=120, sharey=True,
        squeeze=False,
    )  # fmt: skip
    for i, (method, entry) in enumerate(methods):
        ax = axes[i // cols][i % cols]
        _curve_panel(ax, method, entry, f"C{i % 10}")
        if i % cols == 0:
            ax.set_ylabel("imitation score (%)", fontsize=7)
        if i // cols == rows - 1:
            ax.set_xlabel("time to policy (s)", fontsize=7)
    for j in range(len(methods), rows * cols):
        axes[j // cols][j % cols].set_visible(False)
    tasks = ", ".join(curve.get("tasks", []))
    fig.suptitle(
        f"{curve.get('domain', '')}: score against budget ({tasks}); dashed: the paper, same tasks",
        fontsize=8,
    )
    fig.tight_layout()
    return _save(fig, out)


def _curve_panel(ax: Any, method: str, entry: dict[str, Any], colour: str) -> None:
    pts = entry["points"]
    xs, ys = [p["seconds_median"] for p in pts], [p["score_pct"] for p in pts]
    err = [0.0 if math.isnan(p["ci95_pct"]) else p["ci95_pct"] for p in pts]
    ax.errorbar(xs, ys, yerr=err, color=colour, marker="o", ms=4, capsize=2)
    for p, x, y in zip(pts, xs, ys, strict=True):
        ax.annotate(f"×{p['scale']:g}", (x, y), fontsize=6, xytext=(3, 3), ha="left",
                    textcoords="offset points")  # fmt: skip
    if entry.get("paper_score_pct") is not None:
        ax.axhline(entry["paper_score_pct"], color=colour, ls="--", lw=1)
    ax.set_xscale("log")
    ax.set_xticks(xs, [f"{x:.0f}" for x in xs], minor=False)  # the points' own times
    ax.set_xticks([], minor=True)
    ax.tick_params(labelsize=6)
    ax.set_title(f"{method} ({', '.join(entry.get('tasks', []))})", fontsize=7)


def _fmt(x: float | None) -> str:
    return "–" if x is None or math.isnan(x) else f"{x:.1f}"


def curve_table(curve: dict[str, Any]) -> list[str]:
    """One row per (method, scale): steps, time to policy, score and per-task scores."""
    from fbil.evaluation.families import duration

    tasks = list(curve.get("tasks", []))
    lines = [
        "| method | budget | gradient steps | time to policy | score (%) | ±95% | "
        + " | ".join(tasks)
        + " | paper, same tasks (%) |",
        "|---" * (7 + len(tasks)) + "|",
    ]
    for method, entry in curve["methods"].items():
        paper = _fmt(entry.get("paper_score_pct"))
        for p in entry["points"]:
            steps = ", ".join(f"{k or 'steps'} {v:,}" for k, v in p["steps"].items()) or "–"
            per_task = [_fmt(p["task_scores_pct"].get(t)) for t in tasks]
            lines.append(
                f"| {method} | {p['budget']} | {steps} | {duration(p['seconds_median'])} | "
                f"{_fmt(p['score_pct'])} | {_fmt(p['ci95_pct'])} | "
                + " | ".join(per_task)
                + f" | {paper} |"
            )
    return lines


READING_FLOOR = 5.0  # points: a change smaller than this never counts


def curve_reading(entry: dict[str, Any]) -> dict[str, Any] | None:
    """What a method's curve says about its budget: the change in score from its scale-1
    point (the named budget; else its smallest scale) to its largest scale, against
    max(5 points, the 95 % interval over draws at the scale-1 point). "rises": more budget
    would raise the score; "falls": the named budget's score is not a plateau (longer
    training lowered it); "flat": more budget would not change the conclusion. None
    with fewer than two points."""
    points = sorted(entry.get("points", []), key=lambda p: p["scale"])
    if len(points) < 2:
        return None
    base = next((p for p in points if p["scale"] == 1.0), points[0])
    last = points[-1]
    if last is base:
        return None
    change = last["score_pct"] - base["score_pct"]
    ci = base.get("ci95_pct")
    threshold = max(READING_FLOOR, 0.0 if ci is None or math.isnan(ci) else ci)
    word = "rises" if change > threshold else "falls" if change < -threshold else "flat"
    return {
        "base": base["budget"],
        "last": last["budget"],
        "change": change,
        "threshold": threshold,
        "reading": word,
    }


def reading_table(curve: dict[str, Any]) -> list[str]:
    """One row per method with at least two points: `curve_reading`'s verdict, and the
    entry's `note` (what a later measurement found about the curve) where it has one."""
    rows = []
    for method, entry in curve["methods"].items():
        r = curve_reading(entry)
        if r is not None:
            rows.append(
                f"| {method} | {r['base']} → {r['last']} | {r['change']:+.1f} | "
                f"{r['threshold']:.1f} | {r['reading']} | {entry.get('note', '')} |"
            )
    if not rows:
        return []
    return [
        "| method | budgets | change in score (points) | threshold | reading | note |",
        "|---|---|---|---|---|---|",
        *rows,
        "",
        "Threshold: the larger of 5 points and the 95 % interval over draws at the named "
        "budget. *flat*: more budget would not change the conclusion; *rises*: more "
        "budget raises the score, so the named budget holds the baseline back; *falls*: "
        "longer training lowered the score, so the named budget's figure is a "
        "measurement, not a plateau.",
        "",
    ]


def curve_section(curve: dict[str, Any], out_dir: Path) -> list[str]:
    """The report's part on the baselines' budgets: the figure and the table."""
    fig = curve_figure(curve, out_dir / FIGURE_FILE)
    draws, episodes = curve.get("draws", "?"), curve.get("episodes", "?")
    return [
        "## Baselines: score against training budget",
        "",
        f"Each baseline at its `{curve.get('budget', 'cpu')}` budget with every gradient-step "
        "count scaled (`NAME@SCALE`; widths and batch sizes unchanged), on "
        f"{', '.join(curve.get('tasks', []))} ({draws} demo draws × {episodes} episodes "
        "per point): mean score over tasks and draws against the median time to policy. "
        "Dashed: the paper's score on the same tasks (Tables 5-7). A curve that is flat "
        "at its right end means more training would not change the baseline's score. "
        "A method's score is its mean over the tasks it was run on (the per-task columns; "
        "– where it was not run).",
        "",
        *curve_table(curve),
        "",
        *reading_table(curve),
        f"![score against budget]({fig.name})",
        "",
    ]
