"""Add one baseline's finished grid (the lines of one or more `fbil benchmark --out` files)
to a committed results file, after checking that it is one grid: one method, one domain,
one budget, one data sample (`data_digest`), and every (task, draw) of the domain's tasks
exactly once. Lines the results file already holds for that method are moved to
`--replaced-to` (refused without it), so a rerun replaces a grid rather than mixing two.
Both files are written whole or not at all.

Usage: python scripts/add_grid.py RESULTS GRID.jsonl [GRID.jsonl ...] [--replaced-to PATH]
       [--draws N]
Prints the grid's mean score over its draws (task-averaged per draw), the spread between
the draws' means and the median time to policy.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
from collections import Counter, defaultdict
from pathlib import Path
from typing import Any

from fbil.checkpoint import atomic_write_text
from fbil.envs.registry import get_domain
from fbil.errors import FbilError
from fbil.evaluation.benchmark import read_results


def read_lines(path: Path) -> list[dict[str, Any]]:
    """The lines of a results file (`read_results`, which refuses a bad line); a missing
    grid file is an error, not an empty grid."""
    if not path.is_file():
        raise FbilError(f"{path}: no such file; pass the --out file(s) of `fbil benchmark`")
    return read_results(path, repair=False)


def one(rows: list[dict[str, Any]], field: str) -> Any:
    """The one value every line holds for `field`; an error naming the values otherwise."""
    values = sorted({json.dumps(r.get(field)) for r in rows})
    if len(values) != 1:
        raise FbilError(f"the grid's lines hold several {field} values: {', '.join(values)}")
    return rows[0].get(field)


def check_grid(rows: list[dict[str, Any]], draws: int | None) -> dict[str, Any]:
    """The grid's method, domain, budget, data digest, draws; FbilError if it is not one
    complete grid."""
    if not rows:
        raise FbilError("the grid files hold no lines")
    method, domain = one(rows, "method"), one(rows, "domain")
    budget, digest = one(rows, "budget"), one(rows, "data_digest")
    one(rows, "k")
    one(rows, "demo_set")
    if digest is None:
        raise FbilError("the grid's lines record no data_digest: rerun them with this fbil")
    n_draws = draws if draws is not None else 1 + max(int(r["draw"]) for r in rows)
    tasks = list(get_domain(domain).tasks)
    seen = Counter((r["task"], int(r["draw"])) for r in rows)
    twice = sorted(k for k, n in seen.items() if n > 1)
    if twice:
        raise FbilError(f"(task, draw) pairs more than once: {twice}; keep one line each")
    want = {(t, d) for t in tasks for d in range(n_draws)}
    missing, extra = sorted(want - set(seen)), sorted(set(seen) - want)
    if missing or extra:
        raise FbilError(
            f"not one complete grid of {len(tasks)} tasks x {n_draws} draws: missing {missing}, "
            f"unexpected {extra}"
        )
    return {
        "method": method,
        "domain": domain,
        "budget": budget,
        "digest": digest,
        "draws": n_draws,
    }


def summary(rows: list[dict[str, Any]], draws: int) -> str:
    per_draw: dict[int, list[float]] = defaultdict(list)
    for r in rows:
        per_draw[int(r["draw"])].append(100 * float(r["score"]))
    means = [statistics.fmean(per_draw[d]) for d in range(draws)]
    seconds = statistics.median(float(r["seconds"]) for r in rows)
    each = ", ".join(f"{m:.1f}" for m in means)
    return (
        f"score {statistics.fmean(means):.1f} % (draw means {each}), "
        f"median {seconds:.0f} s to a policy"
    )


def add_grid(
    results: Path,
    grids: list[Path],
    replaced_to: Path | None,
    draws: int | None = None,
) -> str:
    """Check the grid, write RESULTS with it (and REPLACED_TO with the method's old lines);
    the one-line summary."""
    rows = [r for g in grids for r in read_lines(g)]
    grid = check_grid(rows, draws)
    old = read_lines(results) if results.exists() else []
    if old and {r.get("domain") for r in old} != {grid["domain"]}:
        raise FbilError(f"{results} holds results of another domain than {grid['domain']}")
    kept = [r for r in old if r.get("method") != grid["method"]]
    moved = [r for r in old if r.get("method") == grid["method"]]
    if moved and replaced_to is None:
        raise FbilError(
            f"{results} already holds {len(moved)} {grid['method']} lines; pass --replaced-to "
            "PATH to move them there"
        )
    if moved and replaced_to is not None:
        if replaced_to.exists():
            raise FbilError(f"{replaced_to} exists; name a new file for the replaced lines")
        atomic_write_text(replaced_to, "".join(json.dumps(r) + "\n" for r in moved))
    atomic_write_text(results, "".join(json.dumps(r) + "\n" for r in kept + rows))
    head = (
        f"{grid['method']} on {grid['domain']}: {len(rows)} lines, budget {grid['budget']}, "
        f"data {grid['digest']}"
    )
    tail = f"; {len(moved)} old lines moved to {replaced_to}" if moved else ""
    return f"{head}; {summary(rows, grid['draws'])}{tail}"


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("results", type=Path)
    p.add_argument("grids", type=Path, nargs="+")
    p.add_argument("--replaced-to", type=Path, default=None)
    p.add_argument("--draws", type=int, default=None, help="default: the grid's highest + 1")
    args = p.parse_args(argv)
    try:
        print(add_grid(args.results, args.grids, args.replaced_to, args.draws))
    except FbilError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
