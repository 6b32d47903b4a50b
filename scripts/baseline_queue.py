"""What is left of the baselines' grids (issue #22), per domain and method, and what it costs.

A grid is every task of the domain at K = 1 on the standard demos, `--draws` draws (2), one
training seed, at the method's `auto` budget for that domain. A (task, draw) counts as
committed when the domain's `artifacts/results/DOMAIN/baselines.jsonl` holds it for the
method at any budget (a committed grid is whole: `scripts/add_grid.py`), and as carried when
a line of a `carry/*/*.jsonl` or an `--extra` file (e.g. `runs/baselines/*.jsonl`) holds it
at the `auto` budget. The cost of a job is the median `seconds` of the method's lines on
that domain and budget (committed, carried or extra); without such lines, the projection of
the domain's `artifacts/results/DOMAIN/time_to_policy.json` (`benchmarks/time_to_policy.py
--baselines`) where it was made at that budget, marked `(projected)`; else `?`. A figure is
only as good as the machine it ran on, which the table names.

Usage: python scripts/baseline_queue.py [--domains walker,cheetah] [--draws 2]
       [--extra FILE ...] [--json FILE]
"""

from __future__ import annotations

import argparse
import glob
import json
import statistics
import sys
from pathlib import Path
from typing import Any

from fbil.baselines import BASELINES
from fbil.checkpoint import atomic_write_text
from fbil.envs.registry import get_domain
from fbil.errors import FbilError
from fbil.evaluation.benchmark import read_results
from fbil.imitators.budgets import resolve_auto

ROOT = Path(__file__).resolve().parents[1]


def _standard(line: dict[str, Any], domain: str, method: str) -> bool:
    return (
        line.get("domain") == domain
        and line.get("method") == method
        and line.get("k", 1) == 1
        and line.get("demo_set", "standard") == "standard"
    )


def projected(timing: dict[str, Any], method: str, budget: str) -> float | None:
    """Seconds a job takes by a `time_to_policy.json` made at `budget`, else None."""
    entry = timing.get("baselines", {}).get(method, {})
    return entry.get("projected_seconds") if entry.get("budget") == budget else None


def queue_row(
    domain: str,
    method: str,
    committed: list[dict],
    others: list[dict],
    draws: int,
    timing: dict[str, Any] | None = None,
) -> dict[str, Any]:
    """One method's state on one domain: jobs committed, carried, left, minutes a job."""
    budget = resolve_auto("auto", method, domain)
    jobs = {(t, d) for t in get_domain(domain).tasks for d in range(draws)}
    mine = [r for r in committed if _standard(r, domain, method)]
    done = {(r["task"], r["draw"]) for r in mine} & jobs
    same = [r for r in others if _standard(r, domain, method) and r.get("budget") == budget]
    carried = {(r["task"], r["draw"]) for r in same} & jobs - done
    timed = [r for r in [*mine, *same] if r.get("budget") == budget and "seconds" in r]
    minutes = statistics.median(r["seconds"] for r in timed) / 60 if timed else None
    machines = sorted({str(r.get("machine") or "?").split(",")[0] for r in timed})
    guess = None if timed or timing is None else projected(timing, method, budget)
    if guess is not None and timing is not None:
        minutes = guess / 60
        machines = [str(timing.get("machine") or "?").split(",")[0] + " (projected)"]
    left = len(jobs) - len(done) - len(carried)
    return {
        "domain": domain,
        "method": method,
        "budget": budget,
        "jobs": len(jobs),
        "committed": len(done),
        "carried": len(carried),
        "left": left,
        "minutes_per_job": minutes,
        "core_hours_left": None if minutes is None else left * minutes / 60,
        "machines": machines,
    }


def read_many(paths: list[Path]) -> list[dict[str, Any]]:
    return [line for p in paths if p.is_file() for line in read_results(p, repair=False)]


def table(rows: list[dict[str, Any]]) -> str:
    out = [
        "| domain | method | budget | jobs | committed | carried | left | min/job | core-h left "
        "| timed on |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        if r["left"] == 0 and r["carried"] == 0:
            continue  # a finished grid
        m = "?" if r["minutes_per_job"] is None else f"{r['minutes_per_job']:.0f}"
        h = "?" if r["core_hours_left"] is None else f"{r['core_hours_left']:.1f}"
        cells = [r["domain"], r["method"], r["budget"], r["jobs"], r["committed"], r["carried"]]
        cells += [r["left"], m, h, ", ".join(r["machines"]) or "–"]
        out.append("| " + " | ".join(str(c) for c in cells) + " |")
    known = [r["core_hours_left"] for r in rows if r["core_hours_left"] is not None]
    unknown = sum(r["left"] for r in rows if r["core_hours_left"] is None)
    out.append(
        f"\ncore-hours left: {sum(known):.1f} over the timed methods"
        + (f", plus {unknown} jobs not timed yet" if unknown else "")
    )
    return "\n".join(out)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--domains", default="walker,cheetah")
    ap.add_argument("--draws", type=int, default=2)
    ap.add_argument("--extra", nargs="*", default=[], help="more results files (runs/...)")
    ap.add_argument("--json", type=Path)
    args = ap.parse_args(argv)
    try:
        others = read_many(
            [*map(Path, sorted(glob.glob(str(ROOT / "carry/*/*.jsonl")))), *map(Path, args.extra)]
        )
        rows = []
        for domain in args.domains.split(","):
            get_domain(domain)  # an unknown name: one line
            folder = ROOT / "artifacts/results" / domain
            committed = read_many([folder / "baselines.jsonl"])
            timing_file = folder / "time_to_policy.json"
            timing = json.loads(timing_file.read_text()) if timing_file.is_file() else None
            rows += [
                queue_row(domain, b.name, committed, others, args.draws, timing) for b in BASELINES
            ]
    except FbilError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    print(table(rows))
    if args.json:
        try:
            atomic_write_text(args.json, json.dumps(rows, indent=1) + "\n")
        except OSError as e:
            print(
                f"error: cannot write {args.json} ({e.strerror}); pick a writable path",
                file=sys.stderr,
            )
            return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
