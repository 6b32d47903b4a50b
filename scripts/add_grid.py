"""Add one baseline's finished grid (the lines of one or more `fbil benchmark --out` files) to
a committed results file, after checking that it is one grid: one method, one domain, one
budget, one data sample (`data_digest`, for a method that trains on data), and every (task,
draw) of the domain's tasks exactly once, at one training seed. Lines the results file
already holds for that method are moved to `--replaced-to` (refused without it), so a rerun
replaces a grid rather than mixing two; with `--add-seed`, only the method's lines of the
grid's own seed are, and its lines of other seeds stay (they must have the grid's budget
and data sample): a grid run again with `fbil benchmark --seed`, which `fbil report`
averages per draw. Both files are written whole or not at all.

Usage: python scripts/add_grid.py RESULTS GRID.jsonl [GRID.jsonl ...] [--replaced-to PATH]
       [--draws N] [--add-seed]
Prints the grid's mean score over its draws (task-averaged per draw), the draws' means and
the median time to policy; with --add-seed, also the method's score over all its seeds.
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
from fbil.imitators.registry import get_imitator


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
    seed = int(one(rows, "seed") or 0)
    imitator = get_imitator(str(method))
    if digest is None and (imitator.needs_dataset or imitator.needs_goal_model):
        # a method that trains on no dataset (bc: the demos alone) records none
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
        "seed": seed,
    }


def draw_means(rows: list[dict[str, Any]], draws: int) -> list[float]:
    """Per draw, the task-averaged score (%), averaged over the seeds that ran the draw."""
    per_run: dict[tuple[int, int], list[float]] = defaultdict(list)
    for r in rows:
        per_run[(int(r["draw"]), int(r.get("seed") or 0))].append(100 * float(r["score"]))
    return [
        statistics.fmean(statistics.fmean(v) for (d, _), v in per_run.items() if d == draw)
        for draw in range(draws)
    ]


def summary(rows: list[dict[str, Any]], draws: int) -> str:
    means = draw_means(rows, draws)
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
    add_seed: bool = False,
) -> str:
    """Check the grid, write RESULTS with it (and REPLACED_TO with the method's old lines
    it replaces: all of them, or with `add_seed` those of the grid's seed); the one-line
    summary."""
    rows = [r for g in grids for r in read_lines(g)]
    grid = check_grid(rows, draws)
    old = read_lines(results) if results.exists() else []
    if old and {r.get("domain") for r in old} != {grid["domain"]}:
        raise FbilError(f"{results} holds results of another domain than {grid['domain']}")
    mine = [r for r in old if r.get("method") == grid["method"]]
    moved = [r for r in mine if not add_seed or int(r.get("seed") or 0) == grid["seed"]]
    gone = {id(r) for r in moved}
    seeds = [r for r in mine if id(r) not in gone]
    if seeds:
        check_same_grid(seeds, grid)
    if moved and replaced_to is None:
        raise FbilError(
            f"{results} already holds {len(moved)} {grid['method']} lines"
            + (f" of seed {grid['seed']}" if add_seed else "")
            + "; pass --replaced-to PATH to move them there"
        )
    if moved and replaced_to is not None:
        if replaced_to.exists():
            raise FbilError(f"{replaced_to} exists; name a new file for the replaced lines")
        atomic_write_text(replaced_to, "".join(json.dumps(r) + "\n" for r in moved))
    kept = [r for r in old if id(r) not in gone]
    atomic_write_text(results, "".join(json.dumps(r) + "\n" for r in kept + rows))
    head = (
        f"{grid['method']} on {grid['domain']}: {len(rows)} lines, budget {grid['budget']}, "
        f"data {grid['digest']}, seed {grid['seed']}"
    )
    tail = f"; {len(moved)} old lines moved to {replaced_to}" if moved else ""
    if seeds:
        every = seeds + rows
        n = sorted({int(r.get("seed") or 0) for r in every})
        tail += f"; over seeds {', '.join(map(str, n))}: {summary(every, grid['draws'])}"
    return f"{head}; {summary(rows, grid['draws'])}{tail}"


def check_same_grid(others: list[dict[str, Any]], grid: dict[str, Any]) -> None:
    """The method's lines of other seeds must be a grid of the same budget and data."""
    for field, key in (("budget", "budget"), ("data_digest", "digest")):
        found = sorted({str(r.get(field)) for r in others} - {str(grid[key])})
        if found:
            raise FbilError(
                f"--add-seed: the results' other {grid['method']} seeds have {field} "
                f"{', '.join(found)}, the grid {grid[key]}; add a seed only to a grid of the "
                "same budget and data (or replace the grid without --add-seed)"
            )


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("results", type=Path)
    p.add_argument("grids", type=Path, nargs="+")
    p.add_argument("--replaced-to", type=Path, default=None)
    p.add_argument("--draws", type=int, default=None, help="default: the grid's highest + 1")
    p.add_argument(
        "--add-seed",
        action="store_true",
        help="keep the method's lines of other seeds (same budget and data): a second seed",
    )
    args = p.parse_args(argv)
    try:
        print(add_grid(args.results, args.grids, args.replaced_to, args.draws, args.add_seed))
    except FbilError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
