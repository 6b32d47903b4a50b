"""`fbil report`: a Markdown report with figures from a benchmark's results.jsonl.

Sections per domain: mean imitation score per method next to the paper (with 95%
confidence intervals over demo draws), per-task returns of every method (FB-IL and
baselines) next to the paper's Tables 5-7, the score by family and IL principle (the
paper's Fig. 3), time to policy of every method on a log scale next to Table 8 (Fig. 2),
the baselines' score against training budget when a budget curve is there
(`fbil.evaluation.budget_curve`), the model seeds' spread when a seeds.json is there
(`fbil.evaluation.seeds`), several recipes over their seeds when a recipes.json is there
(`fbil.evaluation.recipes`), one run's imitation against its training length when a
training_curve.json is there (`fbil.evaluation.training_curve`), the demo-shift and K
comparisons when the results hold them, and the demonstration against each method's
rollout in the domain's picture (the maze: paths, as the paper's Fig. 6; locomotion: frame
strips). Results files of several domains (one domain per file): one such report per
domain and a report over domains (the paper's Fig. 1).
"""

from __future__ import annotations

import math
from collections import defaultdict
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from fbil.checkpoint import atomic_write_text
from fbil.envs import max_return
from fbil.errors import FbilError
from fbil.evaluation.benchmark import drawn_by_report, read_results
from fbil.evaluation.budget_curve import curve_section, find_curve, read_curve
from fbil.evaluation.families import (
    duration,
    groups,
    groups_figure,
    groups_table,
    mean_over_domains,
    order,
    over_domains,
    time_figure,
    time_table,
)
from fbil.evaluation.implied import find_implied, implied_section
from fbil.evaluation.paper import (
    PAPER_RETURNS,
    PAPER_SCORES,
    PAPER_TIMES,
    above_max_return,
    paper_score,
)
from fbil.evaluation.recipes import find_recipes, recipes_section
from fbil.evaluation.seeds import find_seeds, seeds_section
from fbil.evaluation.timing import find_timing, timing_section
from fbil.evaluation.training_curve import find_training_curve, training_curve_section
from fbil.imitators import family_of, principle_of


def _ci95(values: Sequence[float]) -> float:
    v = np.asarray(values, float)
    return float(1.96 * v.std(ddof=1) / math.sqrt(len(v))) if len(v) > 1 else float("nan")


def _check_budgets(rows: Sequence[dict[str, Any]]) -> None:
    budgets: dict[str, set[str]] = defaultdict(set)
    for r in rows:
        budgets[r["method"]].add(str(r.get("budget")))
    mixed = sorted(m for m, b in budgets.items() if len(b) > 1)
    if mixed:
        raise FbilError(
            f"the results hold several budgets of {', '.join(mixed)}; report one budget per "
            "results file (run `fbil benchmark` with a separate --out per budget)"
        )


Run = tuple[int, int]  # (demo draw, training seed): one job of a method on a task


def summarise(rows: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """Scores and returns per (demo_set, k) setting, method and task."""
    domains = sorted({r["domain"] for r in rows})
    if len(domains) > 1:
        raise FbilError(
            f"the results mix domains ({', '.join(domains)}); report one domain per "
            "results file (run `fbil benchmark` with a separate --out per domain)"
        )
    _check_budgets(rows)
    cells: dict[tuple[str, int], dict[str, dict[str, dict[Run, dict[str, Any]]]]] = defaultdict(
        lambda: defaultdict(lambda: defaultdict(dict))
    )
    for r in rows:
        if "score" in r:
            run = (int(r["draw"]), int(r.get("seed") or 0))
            cells[(r["demo_set"], r["k"])][r["method"]][r["task"]][run] = r
    settings = {
        f"{setting[0]}, K={setting[1]}": {
            method: _method_summary(method, per_task) for method, per_task in per_method.items()
        }
        for setting, per_method in cells.items()
    }
    return {"domain": domains[0] if domains else None, "settings": settings}


def _seed_scores(per_run: dict[Run, float]) -> dict[int, float]:
    """Each training seed's task-averaged score over the draws that every seed has (empty
    for one seed): the seed-to-seed spread of a grid run more than once."""
    seeds = sorted({s for _, s in per_run})
    if len(seeds) < 2:
        return {}
    draws = set.intersection(*({d for d, s2 in per_run if s2 == s} for s in seeds))
    if not draws:
        return {}
    return {s: float(np.mean([per_run[(d, s)] for d in sorted(draws)])) for s in seeds}


def _task_seed_gaps(per_task: dict[str, dict[Run, dict[str, Any]]]) -> dict[str, float]:
    """Per task, the largest gap between two training seeds' scores, each seed's score the
    mean over the draws that every seed has (empty for one seed): the spread a per-task
    comparison with another method must exceed to be read."""
    gaps: dict[str, float] = {}
    for task, runs in per_task.items():
        per_run = {run: float(c["score"]) for run, c in runs.items()}
        per_seed = _seed_scores(per_run)
        if per_seed:
            gaps[task] = max(per_seed.values()) - min(per_seed.values())
    return gaps


def _method_summary(method: str, per_task: dict[str, dict[Run, dict[str, Any]]]) -> dict[str, Any]:
    """One method in one setting: its score over tasks and draws (a draw's training seeds
    averaged first), per-task returns, each seed's score, the median time to policy over
    its jobs, and its family and IL principle."""
    tasks = sorted(per_task)
    runs = sorted(set.intersection(*(set(per_task[t]) for t in tasks)))
    # Task-averaged score per run; per draw, the mean over its seeds: the interval's unit.
    per_run = {run: float(np.mean([per_task[t][run]["score"] for t in tasks])) for run in runs}
    by_draw: dict[int, list[float]] = defaultdict(list)
    for (d, _), v in per_run.items():
        by_draw[d].append(v)
    per_draw = [float(np.mean(v)) for v in by_draw.values()]
    jobs = [c for t in tasks for c in per_task[t].values()]
    return {
        "score": float(np.mean(per_draw)) if per_draw else float("nan"),
        "ci95": _ci95(per_draw),
        "draws": len(per_draw),
        "seeds": len({s for _, s in runs}),
        "seed_scores": _seed_scores(per_run),
        "task_seed_gaps": _task_seed_gaps(per_task),
        "tasks": {
            t: {
                "return_mean": float(np.mean([c["return_mean"] for c in per_task[t].values()])),
                "return_std": float(np.std([c["return_mean"] for c in per_task[t].values()])),
                "score": float(np.mean([c["score"] for c in per_task[t].values()])),
                "expert_return": float(next(iter(per_task[t].values()))["expert_return"]),
            }
            for t in tasks
        },
        "seconds_median": float(np.median([c["seconds"] for c in jobs])),
        "jobs": len(jobs),
        "budget": jobs[0].get("budget"),  # one per method and domain (`_check_budgets`)
        # Older results lines carry no family; the registry knows it.
        "family": jobs[0].get("family") or family_of(method) or "–",
        "principle": jobs[0].get("principle") or principle_of(method),
    }


def _fmt(x: float, digits: int = 1) -> str:
    return "–" if x is None or (isinstance(x, float) and math.isnan(x)) else f"{x:.{digits}f}"


def _score_figure(summary: dict[str, Any], setting: str, out: Path) -> Path:
    from fbil.envs.render import _pyplot, _save

    plt = _pyplot()
    methods = summary["settings"][setting]
    names = order(set(methods))
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
        if r.get("trajectory") and drawn_by_report(r):
            by_task[r["task"]][r["method"]] = np.asarray(r["trajectory"])
            demo_files[r["task"]] = r["demos"]
    lines: list[str] = []
    for task in sorted(by_task):
        try:
            demo = Demos.load(demo_files[task]).trajectories[0]
        except (FbilError, OSError):
            continue  # the demo file is not on this machine: no picture for this task
        rollouts = {m: by_task[task][m] for m in order(set(by_task[task]))}
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
        "How each committed model's zero-shot returns move with training (learning curves, "
        "ablations) is in the fbil repository's docs/, one page per domain.",
        "",
        "| task | expert | paper expert | expert / paper | zero-shot return "
        "| best imitation return (method) |",
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
        for m in order(set(methods)):
            per = methods[m]["tasks"]
            sub = [per[t]["score"] for t in good if t in per]
            lines.append(
                f"| {m} | {_fmt(100 * methods[m]['score'])} | "
                f"{_fmt(100 * float(np.mean(sub)) if sub else float('nan'))} |"
            )
    return [*lines, ""]


def write_report(
    results: str | Path | Sequence[str | Path],
    out_dir: str | Path,
    budget_curve: str | Path | None = None,
) -> Path:
    """Write OUT/report.md (+ PNGs) from results files, each of one domain. Files of several
    domains: each domain's report in OUT/<domain>/, and OUT/report.md over the domains.
    `budget_curve` (default: a budget_curve.json next to a results file, if any): the
    baselines' score against training budget, in the report of its domain."""
    files = [results] if isinstance(results, (str, Path)) else list(results)
    by_domain = _rows_by_domain(files)
    summaries = {domain: summarise(rows) for domain, (_, rows) in by_domain.items()}
    curve = _budget_curve(files, budget_curve, set(by_domain))
    out_dir = Path(out_dir)
    if len(by_domain) == 1:
        ((domain, (domain_files, rows)),) = by_domain.items()
        return _domain_report(domain_files, rows, summaries[domain], out_dir, curve)
    for domain, (domain_files, rows) in by_domain.items():
        _domain_report(domain_files, rows, summaries[domain], out_dir / domain, curve)
    return _over_domains_report(files, summaries, out_dir)


def _budget_curve(
    files: Sequence[str | Path], explicit: str | Path | None, domains: set[str]
) -> dict[str, Any] | None:
    """The budget curve to report (`find_curve`); one passed explicitly must be of a
    reported domain."""
    path = find_curve(files, explicit)
    if path is None:
        return None
    curve = read_curve(path)
    if curve.get("domain") not in domains:
        if explicit is None:
            return None  # a curve found next to the results, of another domain: not theirs
        raise FbilError(
            f"the budget curve {path} is of {curve.get('domain')}, the results of "
            f"{', '.join(sorted(domains))}; pass a curve of a reported domain"
        )
    return curve


def _rows_by_domain(
    files: Sequence[str | Path],
) -> dict[str, tuple[list[str | Path], list[dict[str, Any]]]]:
    """Domain -> (its files, their rows), in the order given; a file must hold one domain."""
    grouped: dict[str, tuple[list[str | Path], list[dict[str, Any]]]] = {}
    for f in files:
        rows = read_results(f, repair=False)
        domains = sorted({r["domain"] for r in rows})
        if len(domains) > 1:
            raise FbilError(
                f"the results in {f} mix domains ({', '.join(domains)}); report one domain "
                "per results file (run `fbil benchmark` with a separate --out per domain)"
            )
        if domains:
            entry = grouped.setdefault(domains[0], ([], []))
            entry[0].append(f)
            entry[1].extend(rows)
    if not grouped:
        raise FbilError(f"no results in {', '.join(map(str, files))}; run `fbil benchmark` first")
    return grouped


def _provenance(rows: Sequence[dict[str, Any]]) -> list[str]:
    """The kinds of CPU the jobs ran on, and a warning for each method whose lines were
    trained on more than one dataset (a regeneration on another kind of CPU is a new sample
    of the recipe, not a copy; lines written before session 24 record neither)."""
    machines = sorted({str(r["machine"]) for r in rows if r.get("machine")})
    unknown = sum(1 for r in rows if not r.get("machine"))
    rest = f" ({unknown} of {len(rows)} lines, older ones, record none)" if unknown else ""
    lines = [f"Machines: {'; '.join(machines)}{rest}.", ""] if machines else []
    digests: dict[str, set[str]] = defaultdict(set)
    for r in rows:
        if r.get("data_digest"):
            digests[r["method"]].add(str(r["data_digest"]))
    for method, found in sorted(digests.items()):
        if len(found) > 1:
            lines += [
                f"**Note:** {method}'s lines were trained on {len(found)} different datasets "
                f"(data_digest {', '.join(sorted(found))}): same path, another regeneration.",
                "",
            ]
    return lines


def _main_setting(summary: dict[str, Any]) -> str | None:
    """The standard K=1 setting when there is one (the paper's figures), else the first."""
    main = next((s for s in summary["settings"] if s.startswith("standard, K=1")), None)
    return main or next(iter(summary["settings"]), None)


def _domain_report(
    files: Sequence[str | Path],
    rows: Sequence[dict[str, Any]],
    summary: dict[str, Any],
    out: Path,
    curve: dict[str, Any] | None = None,
) -> Path:
    out.mkdir(parents=True, exist_ok=True)
    domain = summary["domain"]
    commits = sorted({r.get("commit", "unknown") for r in rows})
    lines = [
        f"# fbil benchmark report: {domain}",
        "",
        f"Results: {', '.join(str(f) for f in files)} ({len(rows)} jobs; commits "
        f"{', '.join(c[:10] for c in commits)}). Imitation score = return of the imitation "
        "policy / the expert's mean return, over 1000-step episodes from the standard start. "
        "Intervals: 95% over demo draws (task-averaged score per draw, averaged over training "
        "seeds where a method has several). Paper: Pirotta et al. "
        "2024, 10 GPU-trained FB models, 1000 episodes, 20 draws.",
        "",
    ]
    lines += _provenance(rows)
    for setting, methods in summary["settings"].items():
        lines += _setting_section(summary, setting, methods, out)
    main = _main_setting(summary)
    if main:
        lines += _impossible_section(domain, summary["settings"][main])
        lines += _groups_section(summary, main, out)
        lines += _time_section(summary, main, out)
        timing = find_timing(files, domain)  # benchmarks/time_to_policy.py --baselines
        if timing is not None:
            lines += timing_section(timing)
        if curve is not None and curve.get("domain") == domain:
            lines += curve_section(curve, out)  # the baselines' score against budget
        lines += _limits_section(rows, summary["settings"][main], domain, main)
        training = find_training_curve(files, domain)  # scripts/compare_models.py --curve
        if training is not None:
            lines += training_curve_section(training, out)
        implied = find_implied(files, domain)  # scripts/implied_reward_probe.py
        if implied is not None:
            lines += implied_section(implied)
        seeds = find_seeds(files, domain)  # several models of one recipe (issue #23)
        if seeds is not None:
            lines += seeds_section(seeds)
        recipes = find_recipes(files, domain)  # several recipes, each over its seeds
        if recipes is not None:
            lines += recipes_section(recipes)
        lines += _other_settings(summary, main)
    lines += _trajectory_figures(domain, rows, out)
    report = out / "report.md"
    atomic_write_text(report, "\n".join(lines) + "\n")
    return report


def _groups_section(summary: dict[str, Any], main: str, out_dir: Path) -> list[str]:
    """The paper's Fig. 3 for this domain: mean score by family and IL principle."""
    cells = groups(summary["settings"][main], summary["domain"])
    fig = groups_figure(cells, f"{summary['domain']}: {main}", out_dir / "families.png")
    return [
        f"## Imitation score by family and IL principle ({main})",
        "",
        "As the paper's Fig. 3: each method's score (mean over tasks and draws), averaged "
        "over the methods of a family and of one of the paper's IL principles (BC, reward, "
        "FM/DM with the Bellman-gap methods, goal-based). Paper: the same mean over the "
        "same methods, from Tables 5-7 (how many of them the paper reports, when not all).",
        "",
        *groups_table(cells),
        "",
        f"![by family and principle]({fig.name})",
        "",
    ]


def _over_domains_report(
    files: Sequence[str | Path], summaries: dict[str, dict[str, Any]], out_dir: Path
) -> Path:
    """OUT/report.md for several domains: links to each domain's report, the paper's Fig. 1
    (score by family and principle, averaged over domains) and times per domain."""
    mains = {d: m for d, s in summaries.items() if (m := _main_setting(s))}
    per_domain = {d: groups(summaries[d]["settings"][m], d) for d, m in mains.items()}
    fig = groups_figure(
        mean_over_domains(per_domain), "over domains", out_dir / "families_over_domains.png"
    )
    lines = [
        f"# fbil benchmark report: {', '.join(summaries)}",
        "",
        f"Results: {', '.join(str(f) for f in files)}. Each domain's report: "
        + ", ".join(f"[{d}]({d}/report.md)" for d in summaries)
        + ".",
        "",
        "## Over domains",
        "",
        "Score (%) by family and IL principle in each domain's standard K=1 setting (the "
        "first setting where there is none), ours (the paper's for the same methods, from "
        "Tables 5-7), and the mean over the domains that have the group, as the paper's "
        "Fig. 1 averages over domains.",
        "",
        *over_domains(per_domain),
        "",
        f"![over domains]({fig.name})",
        "",
        *_times_over_domains(summaries, mains),
    ]
    report = out_dir / "report.md"
    atomic_write_text(report, "\n".join(lines) + "\n")
    return report


def _times_over_domains(summaries: dict[str, dict[str, Any]], mains: dict[str, str]) -> list[str]:
    domains = list(mains)
    found = {m: r for d in domains for m, r in summaries[d]["settings"][mains[d]].items()}
    lines = [
        "### Time to policy per domain (median over jobs)",
        "",
        "| method | family | " + " | ".join(domains) + " | paper, GPU (Table 8) |",
        "|---|---|" + "---|" * (len(domains) + 1),
    ]
    for m in order(set(found)):
        results = [summaries[d]["settings"][mains[d]].get(m) for d in domains]
        # A method's budget may differ between domains (set per domain from a measured
        # curve, e.g. walker's TD3 oracle): then each time names its budget.
        named = len({r.get("budget") for r in results if r}) > 1
        cells = [
            "–"
            if r is None
            else duration(r["seconds_median"]) + (f" ({r.get('budget')})" if named else "")
            for r in results
        ]
        lines.append(
            f"| {m} | {found[m]['family']} | "
            + " | ".join(cells)
            + f" | {PAPER_TIMES.get(m, '–')} |"
        )
    return [*lines, ""]


def _setting_section(
    summary: dict[str, Any], setting: str, methods: dict[str, Any], out_dir: Path
) -> list[str]:
    """Scores (table and figure), returns and per-task scores of one setting."""
    names = order(set(methods))
    paper_scores = PAPER_SCORES.get(summary["domain"], {})
    slug = setting.replace(", ", "_").replace("=", "")
    lines = [f"## Imitation score ({setting})", ""]
    lines += ["| method | principle | score (%) | ±95% | draws | paper (%) | time to policy |"]
    lines += ["|---|---|---|---|---|---|---|"]
    for m in names:
        r = methods[m]
        lines.append(
            f"| {m} | {principle_of(m)} | "
            f"{_fmt(100 * r['score'])} | {_fmt(100 * r['ci95'])} | {_draws(r)} | "
            f"{_fmt(paper_scores.get(m, float('nan')))} | {duration(r['seconds_median'])} |"
        )
    fig = _score_figure(summary, setting, out_dir / f"scores_{slug}.png")
    lines += ["", f"![scores]({fig.name})", ""]
    lines += _training_seeds(methods, names)
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


def _draws(r: dict[str, Any]) -> str:
    """The draws cell: the number of draws, and of training seeds where there are several."""
    return f"{r['draws']} × {r['seeds']} seeds" if r.get("seeds", 1) > 1 else str(r["draws"])


def _training_seeds(methods: dict[str, Any], names: list[str]) -> list[str]:
    """The methods run with several training seeds: each seed's score and the gap, the
    spread a one-seed comparison cannot see."""
    several = [m for m in names if methods[m].get("seed_scores")]
    if not several:
        return []
    lines = [
        "Training seeds: a method run more than once per draw (`fbil benchmark --seed`) is "
        "scored as the mean over its seeds within each draw, then over draws. Each seed's "
        "score over the draws that all its seeds have, the largest gap between two seeds, and "
        "the same gap per task (a per-task difference to another method smaller than twice "
        "it is within seed noise):",
        "",
        "| method | score per seed (%) | seed gap (points) | seed gap per task (points) |",
        "|---|---|---|---|",
    ]
    for m in several:
        per = methods[m]["seed_scores"]
        cells = ", ".join(f"seed {s}: {_fmt(100 * v)}" for s, v in sorted(per.items()))
        gap = 100 * (max(per.values()) - min(per.values()))
        tasks = methods[m].get("task_seed_gaps", {})
        per_task = ", ".join(f"{t} {_fmt(100 * g)}" for t, g in sorted(tasks.items()))
        lines.append(f"| {m} | {cells} | {_fmt(gap)} | {per_task or '–'} |")
    return [*lines, ""]


def _returns_table(
    domain: str, setting: str, methods: dict[str, Any], names: list[str], tasks: list[str]
) -> list[str]:
    paper_returns = PAPER_RETURNS.get(domain, {})
    impossible = above_max_return(domain)
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
            mark = "†" if t in impossible.get(m, {}) else ""
            cells.append(f"{_fmt(ours['return_mean']) if ours else '–'} ({_fmt(paper)}{mark})")
        lines.append(f"| {m} | " + " | ".join(cells) + " |")
    if any(m in impossible for m in names):
        lines += ["", "† above the task's maximum return: see below."]
    return lines


def _impossible_section(domain: str, methods: dict[str, Any]) -> list[str]:
    """The paper's figures that no policy can reach, and each such method compared with the
    paper on the other tasks only."""
    impossible = {m: t for m, t in above_max_return(domain).items() if m in methods}
    if not impossible:
        return []
    lines = [
        "## Paper figures above a task's maximum return",
        "",
        "Each task's reward pays at most `reward_max` per step (1 for every task here), so no "
        "policy returns more than that times the episode length (`fbil.envs.max_return`). A "
        "paper figure above it cannot come from the task's reward as defined, so it is no "
        "target: these methods are compared with the paper on the other tasks too.",
        "",
        "| method | task: paper return (maximum) | fbil there (%) | paper, other tasks (%) "
        "| fbil, other tasks (%) |",
        "|---|---|---|---|---|",
    ]
    for m in order(set(impossible)):
        per = methods[m]["tasks"]
        other = [t for t in per if t not in impossible[m]]
        cells = "; ".join(
            f"{t}: {v:.1f} ({max_return(domain, t):.0f})" for t, v in impossible[m].items()
        )
        there = "; ".join(_fmt(100 * per[t]["score"]) for t in impossible[m] if t in per)
        ours = 100 * float(np.mean([per[t]["score"] for t in other])) if other else math.nan
        paper = paper_score(domain, m, other) if other else math.nan
        lines.append(f"| {m} | {cells} | {there or '–'} | {_fmt(paper)} | {_fmt(ours)} |")
    return [*lines, ""]


def _time_section(summary: dict[str, Any], main: str, out_dir: Path) -> list[str]:
    """The paper's Fig. 2 from our measurements: every method's median time to policy."""
    methods = summary["settings"][main]
    names = order(set(methods))
    title = f"{summary['domain']}: time to policy ({main})"
    fig = time_figure(methods, names, title, out_dir / "time_to_policy.png")
    lines = [
        "## Time to policy",
        "",
        f"Median over jobs ({main}) of the wall time from demonstrations in memory to a "
        "policy (`Imitator.fit`), in the unit that suits it (baselines train for minutes, "
        "FB-IL methods take milliseconds); benchmark workers share the machine, and "
        "`benchmarks/time_to_policy.py` measures FB-IL on a quiet one. The paper's times "
        "(Table 8, GPU, averaged over environments) are marked on the figure.",
        "",
        *time_table(methods, names),
    ]
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
    for m in order(set(base)):
        cells = [_fmt(100 * base[m])] + [
            _fmt(100 * summary["settings"][s][m]["score"]) if m in summary["settings"][s] else "–"
            for s in others
        ]
        lines.append(f"| {m} | " + " | ".join(cells) + " |")
    return [*lines, ""]
