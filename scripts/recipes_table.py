"""Recipes compared (issue #23): several FB training recipes of one domain, each over its
model seeds, into recipes.json; `fbil report` shows it when it sits next to the results.

Each `--arm NAME=SPEC` is one recipe: SPEC is a seeds.json of `scripts/model_seeds.py`
(two or more seeds), or MODEL_DIR@RESULTS.jsonl for a recipe trained with one seed (its
model folder with `zero_shot.json`, and `fbil benchmark --model MODEL_DIR`'s results).
`--describe NAME=TEXT` says what the recipe is. The zero-shot mean is taken over
`--zero-shot-tasks` (default: each seed's own mean, as in its seeds.json).

Usage: python scripts/recipes_table.py --arm A=seeds_a.json --arm B=MODEL@RES.jsonl
           [--describe A=TEXT ...] [--zero-shot-tasks t1,t2] --out DIR_OR_FILE.json
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from fbil.checkpoint import atomic_write_text
from fbil.errors import FbilError
from fbil.evaluation.recipes import RECIPES_FILE, build_arm, build_recipes
from fbil.evaluation.seeds import seed_entry


def _pairs(items: list[str], flag: str) -> list[tuple[str, str]]:
    pairs = []
    for item in items:
        name, sep, value = item.partition("=")
        if not sep or not name or not value:
            raise FbilError(f"{flag} {item!r}: give NAME=VALUE")
        pairs.append((name, value))
    return pairs


def _entries(spec: str, tasks: list[str]) -> list[dict[str, Any]]:
    if "@" in spec:
        model, _, results = spec.partition("@")
        return [seed_entry(model, results, tasks or None)]
    try:
        seeds = json.loads(Path(spec).read_text())
        return list(seeds["seeds"])
    except FileNotFoundError:
        raise FbilError(f"{spec}: no such seeds file (scripts/model_seeds.py writes it)") from None
    except (OSError, ValueError, KeyError, TypeError):
        raise FbilError(f"{spec}: not a seeds.json; rerun scripts/model_seeds.py") from None


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--arm", action="append", required=True, metavar="NAME=SPEC")
    p.add_argument("--describe", action="append", default=[], metavar="NAME=TEXT")
    p.add_argument("--zero-shot-tasks", default="", help="tasks of the zero-shot mean")
    p.add_argument("--out", required=True, help="a folder (recipes.json in it) or a .json file")
    args = p.parse_args(argv)
    tasks = [t.strip() for t in args.zero_shot_tasks.split(",") if t.strip()]
    try:
        arms = _pairs(args.arm, "--arm")
        texts = dict(_pairs(args.describe, "--describe"))
        unknown = sorted(set(texts) - {n for n, _ in arms})
        if unknown:
            raise FbilError(f"--describe names no arm: {', '.join(unknown)}")
        built = [build_arm(n, texts.get(n, ""), _entries(s, tasks), tasks) for n, s in arms]
        recipes = build_recipes(built, tasks)
        out = Path(args.out)
        path = out if out.suffix == ".json" else out / RECIPES_FILE
        path.parent.mkdir(parents=True, exist_ok=True)
        atomic_write_text(path, json.dumps(recipes, indent=1) + "\n")
    except FbilError as exc:
        print(f"recipes_table: error: {exc}", file=sys.stderr)
        return 2
    print(f"{path}: {len(built)} recipes over {len(recipes['methods'])} methods")
    return 0


if __name__ == "__main__":
    sys.exit(main())
