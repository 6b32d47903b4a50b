"""Issue #23's decision between two maze FB recipes, by the rule fixed before the results
(docs/fb-maze-notes.md, "The scratch test"): each arm is a seeds.json of
`scripts/model_seeds.py` (one model per seed, each with its zero-shot returns and its
standard K = 1 grid); the candidate replaces the baseline only if its mean over seeds of
the per-model mean score beats the baseline's by more than the larger seed spread, with a
zero-shot reach mean of at least 500.

Usage: python scripts/recipe_decision.py --baseline SEEDS_A.json --candidate SEEDS_B.json
           [--out DECISION.json]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from fbil.errors import FbilError
from fbil.evaluation.seeds import recipe_decision


def _read(path: str) -> dict:  # type: ignore[type-arg]
    try:
        seeds = json.loads(Path(path).read_text())
        if not isinstance(seeds, dict) or not isinstance(seeds.get("seeds"), list):
            raise ValueError
        return seeds
    except (OSError, ValueError):
        raise FbilError(f"{path}: not a seeds.json of scripts/model_seeds.py") from None


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--baseline", required=True, help="seeds.json of the committed recipe")
    p.add_argument("--candidate", required=True, help="seeds.json of the recipe to test")
    p.add_argument("--out", help="also write the decision as JSON here")
    args = p.parse_args(argv)
    try:
        result = recipe_decision(_read(args.baseline), _read(args.candidate))
        if args.out:
            from fbil.checkpoint import atomic_write_text

            atomic_write_text(args.out, json.dumps(result, indent=1) + "\n")
    except (FbilError, OSError) as exc:
        print(f"recipe_decision: error: {exc}", file=sys.stderr)
        return 2
    for arm in ("baseline", "candidate"):
        a = result[arm]
        per_seed = ", ".join(f"{100 * m:.1f}" for m in a["measure"])
        print(
            f"{arm:9s} mean score {100 * a['mean']:.1f} ± {100 * a['std']:.1f} over {a['n']} "
            f"seeds ({per_seed}); zero-shot reach mean {a['zero_shot_mean']:.1f}"
        )
    print(
        f"difference {100 * result['difference']:+.1f} points, threshold "
        f"{100 * result['threshold']:.1f}: {result['decision']}"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
