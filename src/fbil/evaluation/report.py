"""`fbil report`: a Markdown report with figures from a benchmark's results.jsonl.

Sections: mean imitation score per method next to the paper (with 95% confidence
intervals over demo draws), per-task returns next to the paper's Table 5, time to policy
next to Table 8, the demo-shift and K comparisons when the results hold them, and the
demonstration against each method's rollout in the domain's picture (the maze: paths, as
the paper's Fig. 6; locomotion: frame strips).
"""

from __future__ import annotations

import math
from collections import defaultdict
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from fbil.checkpoint import atomic_write_text
from fbil.errors import FbilError
from fbil.evaluation.benchmark import read_results
from fbil.evaluation.paper import PAPER_RETURNS, PAPER_SCORES, PAPER_TIMES
from fbil.imitators import imitators, principle_of


def _order(methods: set[str]) -> list[str]:
    """Registry order (FB-IL's main methods, the others, then the baselines), then any
    name no longer registered."""
    known = [m for m in imitators() if m in methods]
    return known + sorted(methods - set(known))


def _ci95(values: Sequence[float]) -> float:
    v = np.asarray(values, float)
    return float(1.96 * v.std(ddof=1) / math.sqrt(len(v))) if len(v) > 1 else float("nan")


def summarise(rows: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """Scores and returns per (demo_set, k) setting, method and task."""
    domains = sorted({r["domain"] for r in rows})
    if len(domains) > 1:
        raise FbilError(
            f"the results mix domains ({', '.join(domains)}); report one domain per "
            "results file (run `fbil benchmark` with a separate --out per domain)"
        )
    cells: dict[tuple[str, int], dict[str, dict[str, dict[int, dict[str, Any]]]]] = defaultdict(
        lambda: defaultdict(lambda: defaultdict(dict))
    )
    budgets: dict[str, set[str]] = defaultdict(set)
    for r in rows:
        budgets[r["method"]].add(str(r.get("budget")))
        if "score" in r:
            cells[(r["demo_set"], r["k"])][r["method"]][r["task"]][r["draw"]] = r
    mixed = sorted(m for m, b in budgets.items() if len(b) > 1)
    if mixed:
        raise FbilError(
            f"the results hold several budgets of {', '.join(mixed)}; report one budget per "
            "results file (run `fbil benchmark` with a separate --out per budget)"
        )
    settings = {}
    for setting, per_method in cells.items():
        methods = {}
        for method, per_task in per_method.items():
            tasks = sorted(per_task)
            draws = sorted(set.intersection(*(set(per_task[t]) for t in tasks)))
            # Task-averaged score per draw: the repetition unit for the interval.
            per_draw = [np.mean([per_task[t][d]["score"] for t in tasks]) for d in draws]
            methods[method] = {
                "score": float(np.mean(per_draw)) if per_draw else float("nan"),
                "ci95": _ci95(per_draw),
                "draws": len(draws),
                "tasks": {
                    t: {
                        "return_mean": float(
                            np.mean([c["return_mean"] for c in per_task[t].values()])
                        ),
                        "return_std": float(
                            np.std([c["return_mean"] for c in per_task[t].values()])
                        ),
                        "score": float(np.mean([c["score"] for c in per_task[t].values()])),
                        "expert_return": float(next(iter(per_task[t].values()))["expert_return"]),
                    }
                    for t in tasks
                },
                "seconds_median": float(
                    np.median([c["seconds"] for t in tasks for c in per_task[t].values()])
                ),
            }
        settings[f"{setting[0]}, K={setting[1]}"] = methods
    return {"domain": domains[0] if domains else None, "settings": settings}


def _fmt(x: float, digits: int = 1) -> str:
    return "–" if x is None or (isinstance(x, float) and math.isnan(x)) else f"{x:.{digits}f}"


def _score_figure(summary: dict[str, Any], setting: str, out: Path) -> Path:
    from fbil.envs.render import _pyplot, _save

    plt = _pyplot()
    methods = summary["settings"][setting]
    names = _order(set(methods))
    paper = PAPER_SCORES.get(summary["domain"], {})
    x = np.arange(len(names))
    fig, ax = plt.subplots(figsize=(1.0 + 0.8 * len(names), 3.2), dpi=120)
    ours = [100 * methods[m]["score"] for m in names]
    err = [100 * (methods[m]["ci95"] if not math.isnan(methods[m]["ci95"]) else 0) for m in names]
    ax.bar(x - 0.2, ours, 0.4, yerr=err, capsize=2, label="fbil (cpu model)", color="tab:blue")
    ax.bar(x + 0.2, [paper.get(m, 0) for m in names], 0.4, label="paper", color="tab:gray")
    ax.set_xticks(x, [f"{m}\n{principle_of(m)}" for m in names], fontsize=6)
    ax.set_ylabel("imitation score (%)")
    ax.set_title(f"{summary['domain']}: {setting}", fontsize=9)
    ax.legend(fontsize=7)
    return _save(fig, out)


def _time_figure(summary: dict[str, Any], setting: str, out: Path) -> Path:
    from fbil.envs.render import _pyplot, _save

    plt = _pyplot()
    methods = summary["settings"][setting]
    names = _order(set(methods))
    fig, ax = plt.subplots(figsize=(1.0 + 0.7 * len(names), 3.0), dpi=120)
    ax.bar(names, [methods[m]["seconds_median"] for m in names], color="tab:green")
    ax.set_yscale("log")
    ax.set_ylabel("time to policy (s, median)")
    ax.tick_params(axis="x", labelsize=7)
    return _save(fig, out)


def _trajectory_figures(domain: str, rows: Sequence[dict[str, Any]], out_dir: Path) -> list[str]:
    """The domain's picture of the demonstration against each method's kept rollout
    (benchmark rows of the standard K=1 setting, first draw), one per task, under the
    domain's heading; nothing where the domain keeps no rollouts."""
    from fbil.envs import get_domain
    from fbil.envs.hooks import ImitationPicture
    from fbil.imitation.demos import Demos

    pictures = get_domain(domain).hooks.pictures
    if pictures is None:
        return []
    by_task: dict[str, dict[str, Any]] = defaultdict(dict)
    demo_files: dict[str, str] = {}
    for r in rows:
        if r.get("trajectory") and r["demo_set"] == "standard" and r["k"] == 1:
            by_task[r["task"]][r["method"]] = np.asarray(r["trajectory"])
            demo_files[r["task"]] = r["demos"]
    lines: list[str] = []
    for task in sorted(by_task):
        try:
            demo = Demos.load(demo_files[task]).trajectories[0]
        except (FbilError, OSError):
            continue  # the demo file is not on this machine: no picture for this task
        rollouts = {m: by_task[task][m] for m in _order(set(by_task[task]))}
        out = out_dir / f"trajectories_{task}.png"
        path = pictures.imitation(
            ImitationPicture(demo.observation, demo.physics, rollouts, out, task)
        )
        if path is not None:
            lines += [f"### {task}", "", f"![{task}]({path.name})", ""]
    return [f"## {pictures.imitation_heading}", "", *lines] if lines else []


def _zero_shot(rows: Sequence[dict[str, Any]]) -> dict[str, float]:
    """The model's zero-shot returns (its `zero_shot.json`), when the model is on disk."""
    import json

    models = {r.get("model") for r in rows if r.get("model")}
    if len(models) != 1:
        return {}
    path = Path(str(next(iter(models)))) / "zero_shot.json"
    try:
        tasks = json.loads(path.read_text())["tasks"]
        return {t: float(v["return_mean"]) for t, v in tasks.items()}
    except (OSError, ValueError, KeyError, TypeError):
        return {}


def _limits_section(
    rows: Sequence[dict[str, Any]], methods: dict[str, Any], domain: str, setting: str
) -> list[str]:
    """Evidence for what bounds the scores: the experts against the paper's, and the
    model's own zero-shot returns (the reward-aware ceiling of its policies)."""
    tasks = sorted({t for r in methods.values() for t in r["tasks"]})
    expert = {
        t: next(r["tasks"][t]["expert_return"] for r in methods.values() if t in r["tasks"])
        for t in tasks
    }
    paper_expert = PAPER_RETURNS.get(domain, {}).get("expert", {})
    zero_shot = _zero_shot(rows)
    lines = [
        f"## What bounds these scores ({setting})",
        "",
        "An imitation score needs a good expert (the denominator) and a model whose "
        "policies can do the task at all. Zero-shot: the model's policy for the z inferred "
        "from the *true* reward over its dataset (`fbil zero-shot`, the model's "
        "`zero_shot.json`); FB-IL methods see one demonstration instead of the reward. "
        "How the maze model's zero-shot returns move with training length, n-step targets "
        "and B's learning rate: docs/fb-maze-notes.md in the fbil repository.",
        "",
        "| task | expert | paper expert | expert / paper | zero-shot return | best FB-IL return |",
        "|---|---|---|---|---|---|",
    ]
    good = []
    for t in tasks:
        pe = paper_expert.get(t, float("nan"))
        ratio = expert[t] / pe if pe and not math.isnan(pe) else float("nan")
        if ratio >= 0.85:
            good.append(t)
        best = max(
            ((r["tasks"][t]["return_mean"], m) for m, r in methods.items() if t in r["tasks"]),
            default=(float("nan"), "–"),
        )
        lines.append(
            f"| {t} | {_fmt(expert[t])} | {_fmt(pe)} | {_fmt(100 * ratio)} % | "
            f"{_fmt(zero_shot.get(t, float('nan')))} | {_fmt(best[0])} ({best[1]}) |"
        )
    if good and len(good) < len(tasks):
        lines += [
            "",
            f"Mean score over the {len(good)} tasks whose expert reaches ≥ 85 % of the "
            f"paper's ({', '.join(good)}), against the mean over all {len(tasks)}:",
            "",
            "| method | score, all tasks (%) | score, tasks with a ≥ 85 % expert (%) |",
            "|---|---|---|",
        ]
        for m in _order(set(methods)):
            per = methods[m]["tasks"]
            sub = [per[t]["score"] for t in good if t in per]
            lines.append(
                f"| {m} | {_fmt(100 * methods[m]['score'])} | "
                f"{_fmt(100 * float(np.mean(sub)) if sub else float('nan'))} |"
            )
    return [*lines, ""]


def write_report(results: str | Path | Sequence[str | Path], out_dir: str | Path) -> Path:
    """Write OUT/report.md (+ PNGs) from one or more results files of one domain."""
    files = [results] if isinstance(results, (str, Path)) else list(results)
    rows = [r for f in files for r in read_results(f, repair=False)]
    if not rows:
        raise FbilError(f"no results in {', '.join(map(str, files))}; run `fbil benchmark` first")
    summary = summarise(rows)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    domain = summary["domain"]
    commits = sorted({r.get("commit", "unknown") for r in rows})
    lines = [
        f"# fbil benchmark report: {domain}",
        "",
        f"Results: {', '.join(str(f) for f in files)} ({len(rows)} jobs; commits "
        f"{', '.join(c[:10] for c in commits)}). Imitation score = return of the imitation "
        "policy / the expert's mean return, over 1000-step episodes from the standard start. "
        "Intervals: 95% over demo draws (task-averaged score per draw). Paper: Pirotta et al. "
        "2024, 10 GPU-trained FB models, 1000 episodes, 20 draws.",
        "",
    ]
    for setting, methods in summary["settings"].items():
        lines += _setting_section(summary, setting, methods, out_dir)
    # Time to policy, from the standard K=1 setting when there is one.
    main = next((s for s in summary["settings"] if s.startswith("standard, K=1")), None)
    main = main or next(iter(summary["settings"]), None)
    if main:
        lines += _time_section(summary, main, out_dir)
        lines += _limits_section(rows, summary["settings"][main], domain, main)
        lines += _other_settings(summary, main)
    lines += _trajectory_figures(domain, rows, out_dir)
    report = out_dir / "report.md"
    atomic_write_text(report, "\n".join(lines) + "\n")
    return report


def _setting_section(
    summary: dict[str, Any], setting: str, methods: dict[str, Any], out_dir: Path
) -> list[str]:
    """Scores (table and figure), returns and per-task scores of one setting."""
    names = _order(set(methods))
    paper_scores = PAPER_SCORES.get(summary["domain"], {})
    slug = setting.replace(", ", "_").replace("=", "")
    lines = [f"## Imitation score ({setting})", ""]
    lines += ["| method | principle | score (%) | ±95% | draws | paper (%) | time to policy (s) |"]
    lines += ["|---|---|---|---|---|---|---|"]
    for m in names:
        r = methods[m]
        lines.append(
            f"| {m} | {principle_of(m)} | "
            f"{_fmt(100 * r['score'])} | {_fmt(100 * r['ci95'])} | {r['draws']} | "
            f"{_fmt(paper_scores.get(m, float('nan')))} | {r['seconds_median']:.3f} |"
        )
    fig = _score_figure(summary, setting, out_dir / f"scores_{slug}.png")
    lines += ["", f"![scores]({fig.name})", ""]
    tasks = sorted({t for r in methods.values() for t in r["tasks"]})
    lines += _returns_table(summary["domain"], setting, methods, names, tasks)
    # Per-task scores: one task with a weak or negative-return expert can dominate
    # the mean, and this table shows which.
    lines += ["", f"### Imitation score per task ({setting}, %)", ""]
    lines += ["| method | " + " | ".join(tasks) + " |", "|---" * (len(tasks) + 1) + "|"]
    for m in names:
        per = methods[m]["tasks"]
        cells = [_fmt(100 * per[t]["score"]) if t in per else "–" for t in tasks]
        lines.append(f"| {m} | " + " | ".join(cells) + " |")
    return [*lines, ""]


def _returns_table(
    domain: str, setting: str, methods: dict[str, Any], names: list[str], tasks: list[str]
) -> list[str]:
    paper_returns = PAPER_RETURNS.get(domain, {})
    lines = [f"### Returns per task ({setting}): fbil (paper)", ""]
    lines += ["| method | " + " | ".join(tasks) + " |", "|---" * (len(tasks) + 1) + "|"]
    expert = {
        t: next(r["tasks"][t]["expert_return"] for r in methods.values() if t in r["tasks"])
        for t in tasks
    }
    paper_expert = paper_returns.get("expert", {})
    lines.append(
        "| expert | "
        + " | ".join(f"{expert[t]:.1f} ({_fmt(paper_expert.get(t, float('nan')))})" for t in tasks)
        + " |"
    )
    for m in names:
        cells = []
        for t in tasks:
            ours = methods[m]["tasks"].get(t)
            paper = paper_returns.get(m, {}).get(t, float("nan"))
            cells.append(f"{_fmt(ours['return_mean']) if ours else '–'} ({_fmt(paper)})")
        lines.append(f"| {m} | " + " | ".join(cells) + " |")
    return lines


def _time_section(summary: dict[str, Any], main: str, out_dir: Path) -> list[str]:
    methods = summary["settings"][main]
    fig = _time_figure(summary, main, out_dir / "time_to_policy.png")
    lines = [
        "## Time to policy",
        "",
        "Median wall time of `imitate` per job (benchmark workers share the "
        "machine; `benchmarks/time_to_policy.py` measures on a quiet one).",
        "",
        "| method | fbil, CPU (s) | paper, GPU (Table 8) |",
        "|---|---|---|",
    ]
    for m in _order(set(methods)):
        lines.append(f"| {m} | {methods[m]['seconds_median']:.3f} | {PAPER_TIMES.get(m, '–')} |")
    return [*lines, "", f"![time to policy]({fig.name})", ""]


def _other_settings(summary: dict[str, Any], main: str) -> list[str]:
    """Each method's score in every other setting next to the standard one."""
    base = {m: r["score"] for m, r in summary["settings"][main].items()}
    others = [s for s in summary["settings"] if s != main]
    if not others:
        return []
    lines = ["## Other settings against the standard one", ""]
    lines += [
        "| method | " + " | ".join([main, *others]) + " |",
        "|---" * (len(others) + 2) + "|",
    ]
    for m in _order(set(base)):
        cells = [_fmt(100 * base[m])] + [
            _fmt(100 * summary["settings"][s][m]["score"]) if m in summary["settings"][s] else "–"
            for s in others
        ]
        lines.append(f"| {m} | " + " | ".join(cells) + " |")
    return [*lines, ""]
