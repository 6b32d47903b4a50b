"""Model seeds (issue #23): one FB recipe trained with several seeds, each model's zero-shot
returns and its standard K = 1 imitation scores side by side, their mean and spread, and
the default model picked by a rule fixed before any result is seen.

`scripts/model_seeds.py` writes `seeds.json` (what `build_seeds` returns) from each seed's
model folder (its `zero_shot.json` and `config.json`) and results file (`fbil benchmark`'s
lines for that model); `fbil report` adds the section when a `seeds.json` sits next to the
results file.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from fbil.errors import FbilError
from fbil.evaluation.sidecar import find_sidecar

SEEDS_FILE = "seeds.json"
MAIN_SETTING = "standard, K=1"
# The rules a default model may be chosen by. `median_zero_shot`: the seed whose zero-shot
# mean (over the chosen tasks) is the median of the seeds' (the lower one for an even count),
# so neither the luckiest nor the unluckiest run stands for the recipe. `first`: the first
# model given, for a model committed before its recipe's other seeds were trained (walker),
# which later seeds only measure and never replace.
RULES = ("median_zero_shot", "first")


def _zero_shot(model: Path, tasks: Sequence[str] | None) -> tuple[dict[str, float], float]:
    path = model / "zero_shot.json"
    try:
        per_task = {
            t: float(v["return_mean"]) for t, v in json.loads(path.read_text())["tasks"].items()
        }
    except (OSError, ValueError, KeyError, TypeError):
        raise FbilError(
            f"no readable zero-shot returns in {path}; run `fbil zero-shot {model} --data DIR "
            "--tasks all` first"
        ) from None
    chosen = list(tasks) if tasks else sorted(per_task)
    missing = [t for t in chosen if t not in per_task]
    if missing:
        raise FbilError(f"{path} has no return for {', '.join(missing)}; rerun `fbil zero-shot`")
    return per_task, float(np.mean([per_task[t] for t in chosen]))


def _train_seed(model: Path) -> int | None:
    try:
        seed = json.loads((model / "config.json").read_text())["train_config"]["seed"]
        return int(seed)
    except (OSError, ValueError, KeyError, TypeError):
        return None


def seed_entry(
    model: str | Path, results: str | Path, zero_shot_tasks: Sequence[str] | None = None
) -> dict[str, Any]:
    """One seed: its model's zero-shot returns (and their mean over `zero_shot_tasks`, all
    tasks by default) and the standard K = 1 score of each method in its results file,
    keeping only the lines imitated through this model (and the baselines', which need none)."""
    from fbil.evaluation.benchmark import read_results
    from fbil.evaluation.report import summarise

    model = Path(model)
    per_task, mean = _zero_shot(model, zero_shot_tasks)
    rows = [
        r
        for r in read_results(results, repair=False)
        if "score" in r and (not r.get("model") or Path(r["model"]).resolve() == model.resolve())
    ]
    if not rows:
        raise FbilError(f"no results of {model} in {results}; run `fbil benchmark --model {model}`")
    summary = summarise(rows)["settings"].get(MAIN_SETTING)
    if not summary:
        raise FbilError(f"{results} holds no {MAIN_SETTING} results of {model}")
    return {
        "model": str(model),
        "domain": rows[0]["domain"],
        "seed": _train_seed(model),
        "results": str(results),
        "zero_shot": per_task,
        "zero_shot_mean": mean,
        "scores": {m: float(s["score"]) for m, s in summary.items()},
        "draws": {m: int(s["draws"]) for m, s in summary.items()},
        "returns": {  # mean return per task (over draws), for ratios to zero-shot
            m: {t: float(v["return_mean"]) for t, v in s["tasks"].items()}
            for m, s in summary.items()
        },
    }


def spread(values: Sequence[float]) -> dict[str, float]:
    """Mean, sample std (NaN for one value), min, max and count over seeds."""
    v = np.asarray(values, float)
    return {
        "mean": float(v.mean()),
        "std": float(v.std(ddof=1)) if len(v) > 1 else float("nan"),
        "min": float(v.min()),
        "max": float(v.max()),
        "n": len(v),
    }


def choose(entries: Sequence[dict[str, Any]], rule: str) -> str:
    """The default model among the seeds, by `rule` (one of RULES)."""
    if rule not in RULES:
        raise FbilError(f"unknown rule {rule!r}; valid: {', '.join(RULES)}")
    if rule == "first":
        return str(entries[0]["model"])
    ranked = sorted(entries, key=lambda e: (e["zero_shot_mean"], e["model"]))
    return str(ranked[(len(ranked) - 1) // 2]["model"])


def build_seeds(
    entries: Sequence[dict[str, Any]], rule: str, zero_shot_tasks: Sequence[str]
) -> dict[str, Any]:
    """seeds.json: every seed's entry, the mean and spread over seeds of the zero-shot mean
    and of each method's score (methods every seed has), and the model the rule picks."""
    if len(entries) < 2:
        raise FbilError(f"a seed summary needs at least 2 models, got {len(entries)}")
    domains = sorted({e["domain"] for e in entries})
    if len(domains) > 1:
        raise FbilError(f"the seeds' results mix domains ({', '.join(domains)}); one domain")
    domain = domains[0]
    methods = sorted(set.intersection(*(set(e["scores"]) for e in entries)))
    return {
        "domain": domain,
        "rule": rule,
        "zero_shot_tasks": list(zero_shot_tasks),
        "chosen": choose(entries, rule),
        "seeds": list(entries),
        "zero_shot_mean": spread([e["zero_shot_mean"] for e in entries]),
        "scores": {m: spread([e["scores"][m] for e in entries]) for m in methods},
    }


def write_seeds(seeds: dict[str, Any], out: str | Path) -> Path:
    from fbil.checkpoint import atomic_write_text

    path = Path(out)
    if path.suffix != ".json":
        path = path / SEEDS_FILE
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(path, json.dumps(seeds, indent=1) + "\n")
    return path


def find_seeds(files: Sequence[str | Path], domain: str) -> dict[str, Any] | None:
    """The seeds.json next to one of the results files, if it is of `domain`."""
    return find_sidecar(files, SEEDS_FILE, domain, "rerun scripts/model_seeds.py")


def _pct(x: float) -> str:
    return "–" if math.isnan(x) else f"{100 * x:.1f}"


def seeds_section(seeds: dict[str, Any]) -> list[str]:
    """The report's part on model seeds: one row per seed, then mean ± std over seeds."""
    methods = list(seeds["scores"])
    tasks = ", ".join(seeds["zero_shot_tasks"]) or "all tasks"
    zs = seeds["zero_shot_mean"]
    lines = [
        "## Model seeds",
        "",
        f"The same recipe trained with {zs['n']} seeds, each model with its own zero-shot "
        f"check (mean return over {tasks}) and its own standard K=1 grid (score, %). "
        f"Default model, by the rule `{seeds['rule']}` fixed before the results: "
        f"`{seeds['chosen']}`.",
        "",
        "| model (seed) | zero-shot mean | " + " | ".join(methods) + " |",
        "|---|---|" + "---|" * len(methods),
    ]
    for e in seeds["seeds"]:
        mark = " (default)" if e["model"] == seeds["chosen"] else ""
        lines.append(
            f"| `{e['model']}` ({e['seed']}){mark} | {e['zero_shot_mean']:.1f} | "
            + " | ".join(_pct(e["scores"].get(m, float("nan"))) for m in methods)
            + " |"
        )
    std = zs["std"]
    lines.append(
        f"| **mean ± std over seeds** | {zs['mean']:.1f} ± {std:.1f} | "
        + " | ".join(
            f"{_pct(seeds['scores'][m]['mean'])} ± {_pct(seeds['scores'][m]['std'])}"
            for m in methods
        )
        + " |"
    )
    return [*lines, ""]


REACH = ("reach_top_left", "reach_top_right", "reach_bottom_left", "reach_bottom_right")


def recipe_decision(
    baseline: dict[str, Any],
    candidate: dict[str, Any],
    zero_shot_tasks: Sequence[str] = REACH,
    zero_shot_floor: float = 500.0,
) -> dict[str, Any]:
    """Issue #23's rule, fixed before its results (docs/fb-maze-notes.md): two recipes' seed
    summaries (seeds.json each); a model's measure is its mean score over the methods every
    seed of both arms has, an arm's figure the mean over its seeds and its spread their
    sample std. The candidate replaces the baseline only if its figure is higher by more
    than the larger spread and its mean zero-shot return over `zero_shot_tasks` (over
    seeds) is at least `zero_shot_floor`; with fewer than 2 seeds in an arm there is no
    spread, and no decision."""
    arms = {"baseline": baseline, "candidate": candidate}
    methods = sorted(
        set.intersection(*(set(e["scores"]) for a in arms.values() for e in a["seeds"]))
    )
    if not methods:
        raise FbilError("the two arms' seeds share no method; run the same grid for both")
    out: dict[str, Any] = {"methods": methods, "zero_shot_tasks": list(zero_shot_tasks)}
    for name, arm in arms.items():
        measures = [float(np.mean([e["scores"][m] for m in methods])) for e in arm["seeds"]]
        zs = []
        for e in arm["seeds"]:
            missing = [t for t in zero_shot_tasks if t not in e["zero_shot"]]
            if missing:
                raise FbilError(f"{e['model']}: no zero-shot return for {', '.join(missing)}")
            zs.append(float(np.mean([e["zero_shot"][t] for t in zero_shot_tasks])))
        out[name] = {
            "models": [e["model"] for e in arm["seeds"]],
            "measure": measures,
            **{k: v for k, v in spread(measures).items() if k in ("mean", "std", "n")},
            "zero_shot_mean": float(np.mean(zs)),
        }
    b, c = out["baseline"], out["candidate"]
    out["difference"] = c["mean"] - b["mean"]
    if min(b["n"], c["n"]) < 2:
        out["threshold"] = float("nan")
        out["decision"] = "undecided: every arm needs at least 2 seeds for a spread"
        return out
    out["threshold"] = max(b["std"], c["std"])
    if out["difference"] <= out["threshold"]:
        out["decision"] = "keep the baseline: the arms are not told apart"
    elif c["zero_shot_mean"] < zero_shot_floor:
        out["decision"] = (
            f"keep the baseline: the candidate's zero-shot mean is under {zero_shot_floor:g}"
        )
    else:
        out["decision"] = "replace the baseline by the candidate"
    return out
