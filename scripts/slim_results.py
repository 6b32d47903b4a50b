"""Drop the `trajectory` of results lines that `fbil report` does not draw (K > 1, shifted
demos, later draws; `fbil benchmark` stopped writing them in session 60), rewriting each
file atomically; every other line stays byte for byte.

Usage: python scripts/slim_results.py RESULTS.jsonl [...]
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from fbil.checkpoint import atomic_write_text
from fbil.errors import FbilError
from fbil.evaluation.benchmark import drawn_by_report, read_results


def slim(path: str) -> int:
    """Rewrite `path`; how many trajectories were dropped."""
    if not Path(path).is_file():
        raise FbilError(f"no results file at {path}; pass a .jsonl written by fbil benchmark")
    rows = read_results(path, repair=False)
    kept = [{k: v for k, v in r.items() if k != "trajectory" or drawn_by_report(r)} for r in rows]
    atomic_write_text(path, "".join(json.dumps(r) + "\n" for r in kept))
    return sum(len(r) - len(k) for r, k in zip(rows, kept, strict=True))


def main(argv: list[str] | None = None) -> int:
    files = sys.argv[1:] if argv is None else argv
    if not files:
        print("usage: python scripts/slim_results.py RESULTS.jsonl [...]", file=sys.stderr)
        return 2
    try:
        for f in files:
            print(f"{f}: {slim(f)} trajectories dropped")
    except (FbilError, OSError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
