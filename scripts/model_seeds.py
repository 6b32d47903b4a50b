"""Model seeds (issue #23): several models of one recipe, each with its zero-shot returns
and its own standard K = 1 grid, summarised into seeds.json (per seed, and mean ± std over
seeds) with the default model picked by a rule fixed in advance. `fbil report` shows it when
seeds.json sits next to the results file.

Each `--run MODEL=RESULTS` names a model folder (with the `zero_shot.json` of `fbil
zero-shot MODEL --data DIR --tasks all`) and the results file of `fbil benchmark --model
MODEL ...` for it.

Usage: python scripts/model_seeds.py --run DIR1=RES1.jsonl --run DIR2=RES2.jsonl ...
           [--zero-shot-tasks t1,t2] [--rule median_zero_shot] --out DIR_OR_FILE.json
"""

from __future__ import annotations

import argparse
import sys

from fbil.errors import FbilError
from fbil.evaluation.seeds import RULES, build_seeds, seed_entry, write_seeds


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--run", action="append", required=True, metavar="MODEL=RESULTS")
    p.add_argument("--zero-shot-tasks", default="", help="tasks of the zero-shot mean (all)")
    p.add_argument("--rule", default=RULES[0], help=f"one of {', '.join(RULES)}")
    p.add_argument("--out", required=True, help="a folder (seeds.json in it) or a .json file")
    args = p.parse_args(argv)
    tasks = [t.strip() for t in args.zero_shot_tasks.split(",") if t.strip()]
    try:
        entries = []
        for run in args.run:
            model, sep, results = run.partition("=")
            if not sep or not model or not results:
                raise FbilError(f"--run {run!r}: give MODEL_DIR=RESULTS_FILE")
            entries.append(seed_entry(model, results, tasks or None))
        path = write_seeds(build_seeds(entries, args.rule, tasks), args.out)
    except FbilError as exc:
        print(f"model_seeds: error: {exc}", file=sys.stderr)
        return 2
    print(f"seeds: {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
