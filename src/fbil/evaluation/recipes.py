"""Recipes compared (issue #23): several FB training recipes of one domain side by side, each
an arm of one or more model seeds (the entries of `fbil.evaluation.seeds`), so that the
report shows what each recipe gives with the same demos and evaluation: per arm, the mean
over its seeds of the zero-shot mean and of each method's standard K = 1 score, and the mean
over the methods with its spread over seeds.

`scripts/recipes_table.py` writes `recipes.json` from the arms' seeds.json files (or single
models); `fbil report` adds the section when it sits next to the results file.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from fbil.errors import FbilError
from fbil.evaluation.paper import PAPER_SCORES
from fbil.evaluation.seeds import spread
from fbil.evaluation.sidecar import find_sidecar
from fbil.imitation.methods import MAIN_METHODS

RECIPES_FILE = "recipes.json"
# The method whose return from one demo is set against the model's own zero-shot return
# (issue #23: ERFB's should reach 80 % of z_r's on each of the zero-shot tasks).
RATIO_METHOD = "erfb"
# Below this zero-shot return (5 % of the 1 000 an episode can earn) the model fails the task
# with the true reward itself, and a ratio to that return says nothing: it is left out (null).
ZERO_SHOT_FLOOR = 50.0


def _zero_shot_mean(entry: dict[str, Any], tasks: Sequence[str]) -> float:
    if not tasks:
        return float(entry["zero_shot_mean"])
    missing = [t for t in tasks if t not in entry["zero_shot"]]
    if missing:
        raise FbilError(f"{entry['model']}: no zero-shot return for {', '.join(missing)}")
    return float(np.mean([entry["zero_shot"][t] for t in tasks]))


def build_arm(
    name: str, description: str, entries: Sequence[dict[str, Any]], tasks: Sequence[str]
) -> dict[str, Any]:
    """One recipe: each seed's model, zero-shot mean (over `tasks`, or the entry's own mean)
    and scores."""
    if not entries:
        raise FbilError(f"recipe {name!r} has no model")
    per_seed = [
        {
            "model": str(e["model"]),
            "seed": e.get("seed"),
            "zero_shot_mean": _zero_shot_mean(e, tasks),
            "zero_shot": dict(e.get("zero_shot", {})),
            "scores": dict(e["scores"]),
            "returns": dict(e.get("returns", {})),  # absent from older seeds.json files
        }
        for e in entries
    ]
    return {"name": name, "description": description, "domain": entries[0]["domain"],
            "per_seed": per_seed}  # fmt: skip


def _ratios(seeds: Sequence[dict[str, Any]], method: str, tasks: Sequence[str]) -> dict:
    """Per task, the mean over seeds of `method`'s return from the demos over the same
    model's zero-shot return (the true reward's z); absent where a seed lacks either, None
    where a seed's zero-shot return is below ZERO_SHOT_FLOOR."""
    out: dict[str, float | None] = {}
    for t in tasks:
        pairs = [(s["returns"].get(method, {}).get(t), s["zero_shot"].get(t)) for s in seeds]
        if not pairs or any(r is None or z is None for r, z in pairs):
            continue
        low = any(z < ZERO_SHOT_FLOOR for _, z in pairs)
        out[t] = None if low else float(np.mean([r / z for r, z in pairs]))
    return out


def _summarise(arm: dict[str, Any], methods: Sequence[str], tasks: Sequence[str]) -> dict:
    seeds = arm["per_seed"]
    return {
        "ratio_to_zero_shot": {RATIO_METHOD: _ratios(seeds, RATIO_METHOD, tasks)},
        **arm,
        "seeds": [s["seed"] for s in seeds],
        "zero_shot_mean": spread([s["zero_shot_mean"] for s in seeds]),
        "scores": {m: spread([s["scores"][m] for s in seeds]) for m in methods},
        "mean_of_methods": spread(
            [float(np.mean([s["scores"][m] for m in methods])) for s in seeds]
        ),
    }


def build_recipes(arms: Sequence[dict[str, Any]], tasks: Sequence[str]) -> dict[str, Any]:
    """recipes.json: the arms, in the order given, each summarised over its seeds on the
    methods that every seed of every arm has."""
    if len(arms) < 2:
        raise FbilError(f"a comparison of recipes needs at least 2 arms, got {len(arms)}")
    domains = sorted({a["domain"] for a in arms})
    if len(domains) > 1:
        raise FbilError(f"the recipes mix domains ({', '.join(domains)}); one domain")
    names = [a["name"] for a in arms]
    if len(set(names)) < len(names):
        raise FbilError(f"recipe names repeat ({', '.join(names)}); give each arm its own")
    shared = set.intersection(*(set(s["scores"]) for a in arms for s in a["per_seed"]))
    # The paper's eight in the paper's order, then any other method by name.
    methods = [m for m in MAIN_METHODS if m in shared] + sorted(shared - set(MAIN_METHODS))
    if not methods:
        raise FbilError("the recipes share no method; run the same grid for each")
    return {
        "domain": domains[0],
        "zero_shot_tasks": list(tasks),
        "methods": methods,
        "arms": [_summarise(a, methods, tasks) for a in arms],
    }


def find_recipes(files: Sequence[Any], domain: str) -> dict[str, Any] | None:
    """The recipes.json next to one of the results files, if it is of `domain`."""
    return find_sidecar(files, RECIPES_FILE, domain, "rerun scripts/recipes_table.py")


def _pm(spread: dict[str, float], scale: float, digits: int = 1) -> str:
    mean, std = scale * spread["mean"], scale * spread["std"]
    return f"{mean:.{digits}f}" if math.isnan(std) else f"{mean:.{digits}f} ± {std:.{digits}f}"


def recipes_section(recipes: dict[str, Any]) -> list[str]:
    """The report's part on recipes: one row per arm, mean ± std over its seeds."""
    methods = recipes["methods"]
    tasks = ", ".join(recipes["zero_shot_tasks"]) or "all tasks"
    lines = [
        "## Recipes compared",
        "",
        "FB training recipes of this domain (what each changes is listed below the table), "
        "each trained with the seeds listed; every model has its own zero-shot check (mean "
        f"return over {tasks}) and its own standard K=1 grid with the same demos (score, %). "
        "Mean ± std over seeds (no std with one seed).",
        "",
        "| recipe | seeds | zero-shot mean | " + " | ".join(methods) + " | mean of methods |",
        "|---|---|---|" + "---|" * len(methods) + "---|",
    ]
    for arm in recipes["arms"]:
        scores = [_pm(arm["scores"][m], 100) for m in methods]
        seeds = ", ".join(str(s) for s in arm["seeds"])
        lines.append(
            f"| {arm['name']} | {seeds} | {_pm(arm['zero_shot_mean'], 1)} | "
            + " | ".join(scores)
            + f" | **{_pm(arm['mean_of_methods'], 100)}** |"
        )
    paper = PAPER_SCORES.get(recipes["domain"], {})
    if all(m in paper for m in methods):
        mean = sum(paper[m] for m in methods) / len(methods)
        cells = " | ".join(f"{paper[m]:.1f}" for m in methods)
        lines.append(f"| paper (10 GPU-trained models) | – | – | {cells} | {mean:.1f} |")
    lines += ["", *_ratio_table(recipes)]
    lines += [f"- **{a['name']}**: {a['description']}" for a in recipes["arms"] if a["description"]]
    return [*lines, ""]


def _ratio_table(recipes: dict[str, Any]) -> list[str]:
    """ERFB's return from one demo over the same model's zero-shot return, per task."""
    tasks = recipes["zero_shot_tasks"]
    rows = [(a["name"], a["ratio_to_zero_shot"][RATIO_METHOD]) for a in recipes["arms"]]
    if not tasks or not any(r for _, r in rows):
        return []
    lines = [
        f"{RATIO_METHOD.upper()}'s return from one demo over the same model's zero-shot return "
        "with the true reward, per task (mean over seeds; 1.0: the demo does what the reward "
        "does):",
        "",
        "| recipe | " + " | ".join(tasks) + " |",
        "|---|" + "---|" * len(tasks),
    ]
    for name, ratio in rows:
        cells = [_ratio_cell(ratio, t) for t in tasks]
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    if any(v is None for _, r in rows for v in r.values()):
        lines += ["", f"z_r < {ZERO_SHOT_FLOOR:.0f}: on at least one seed the model's own "
                  "zero-shot return is below that, so it fails the task with the true reward "
                  "and no ratio is shown."]  # fmt: skip
    return [*lines, ""]


def _ratio_cell(ratio: dict[str, float | None], task: str) -> str:
    if task not in ratio:
        return "–"
    value = ratio[task]
    return f"z_r < {ZERO_SHOT_FLOOR:.0f}" if value is None else f"{value:.2f}"
