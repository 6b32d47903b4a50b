"""Score against training budget for offline-IL baselines (issue #22 item 2).

For each scale s of --scales, runs the benchmark grid (--methods x --tasks x --draws) at the
budget `BUDGET@s` (every gradient-step count of the budget multiplied by s; s = 1 is BUDGET
itself) through the benchmark API, one results file per budget under --out
(results_<budget>.jsonl), resumable: a rerun skips every finished line. Then writes
OUT/budget_curve.json (per method and scale: the budget, its step counts, the median time
to policy, the mean score over tasks and draws with its 95% interval, the per-task scores;
per method the paper's score on the same tasks) and OUT/budget_curve.png (score against
time to policy, log x, the paper's score dashed). `fbil report` shows both when
budget_curve.json sits next to the results file or is passed with --budget-curve.

`--reuse FILE` (e.g. the domain's committed baselines.jsonl) copies FILE's lines of the
very jobs a grid would run (same method, task, draw, demos, data, seed, episodes and
budget) on the same data sample (`data_digest`) into that grid's results file first, so they
are not run again: a grid at the `cpu` budget gives the curve its scale-1 point for free.
`--no-run` writes the curve from the lines already in OUT's results files (jobs finished
elsewhere, or a grid cut short), running none. `--merge CURVE` keeps CURVE's entries of
the methods not run now (each with the tasks it was measured on), so a curve grows one
method at a time.

Usage: python scripts/budget_curve.py --methods bc,td3il,sqil \
           --tasks reach_top_left,loop --scales 0.25,0.5,1,2 --draws 2 --episodes 20 \
           --demos DIR [--data DIR] --out DIR [--budget cpu] [--workers N] [--threads N]
           [--reuse RESULTS.jsonl] [--merge budget_curve.json] [--no-run]
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Any

from fbil.checkpoint import atomic_write_text
from fbil.errors import FbilError
from fbil.evaluation.benchmark import _dataset, job_key, make_jobs, read_results, run_benchmark
from fbil.evaluation.budget_curve import (
    build_curve,
    curve_point,
    merge_curves,
    read_curve,
    write_curve,
)
from fbil.evaluation.report import summarise
from fbil.imitators.budgets import scaled_spec


def _names(text: str) -> list[str]:
    return [n.strip() for n in text.split(",") if n.strip()]


def _scales(text: str) -> list[float]:
    try:
        scales = sorted({float(s) for s in _names(text)})
    except ValueError:
        raise FbilError(f"--scales must be numbers > 0 (e.g. 0.25,0.5,1,2), got {text!r}") from None
    if not scales:
        raise FbilError("--scales is empty; give e.g. 0.25,0.5,1,2")
    return scales


def results_file(out: Path, spec: str) -> Path:
    return out / f"results_{spec}.jsonl"


def data_digest(data: str | None) -> str | None:
    """The digest of the unsupervised dataset a grid trains on (None without one), which a
    results line records as `data_digest`; loaded through the benchmark's cache, so the
    in-process jobs that follow do not load it again."""
    return None if data is None else _dataset(str(data)).digest()


def reuse_lines(source: Path, jobs: list[Any], target: Path, digest: str | None = None) -> int:
    """Copy the lines of `source` that finished one of `jobs` on the same data sample
    (`data_digest` equal to `digest`; a regeneration on another CPU is another sample) and
    are not in `target` yet into `target`; how many were copied."""
    wanted = {job.key for job in jobs}
    have = {job_key(r) for r in read_results(target)}
    rows = [
        r
        for r in read_results(source, repair=False)
        if job_key(r) in wanted - have and r.get("data_digest") == digest
    ]
    unique = list({job_key(r): r for r in rows}.values())  # one line per job
    if unique:
        kept = read_results(target)
        atomic_write_text(target, "".join(json.dumps(r) + "\n" for r in [*kept, *unique]))
    return len(unique)


def run_grids(args: argparse.Namespace, scales: list[float]) -> dict[float, tuple[str, Path]]:
    """Every budget's grid, all checked before any runs (a bad method, task, scale or a
    missing dataset is refused first), then run from the smallest budget up."""
    out, grids = Path(args.out), {}
    for scale in scales:
        spec = scaled_spec(args.budget, scale)
        jobs = make_jobs(
            None, args.demos, args.domain, _names(args.tasks), _names(args.methods),
            args.draws, 1, args.episodes, seed=args.seed, data=args.data, budget=spec,
        )  # fmt: skip
        grids[scale] = (spec, jobs)
    from fbil.fb.train import git_commit

    commit = git_commit()
    digest = data_digest(args.data) if args.reuse else None
    for spec, jobs in grids.values():
        if args.reuse:
            out.mkdir(parents=True, exist_ok=True)
            n = reuse_lines(Path(args.reuse), jobs, results_file(out, spec), digest)
            print(f"{spec}: {n} jobs reused from {args.reuse} (data_digest {digest})")
        if args.no_run:
            continue
        started = time.perf_counter()
        new = run_benchmark(jobs, results_file(out, spec), args.workers, commit=commit,
                            threads=args.threads)  # fmt: skip
        wall = time.perf_counter() - started
        print(f"{spec}: {len(new)} jobs run ({wall:.1f} s), {len(jobs) - len(new)} already done")
    return {scale: (spec, results_file(out, spec)) for scale, (spec, _) in grids.items()}


def curve_from_results(
    args: argparse.Namespace, files: dict[float, tuple[str, Path]]
) -> dict[str, Any]:
    """The curve from the results files: each point summarises one method's finished jobs
    (on the requested tasks) at one budget."""
    methods, tasks = _names(args.methods), _names(args.tasks)
    points: dict[str, list[dict[str, Any]]] = {m: [] for m in methods}
    for scale, (spec, path) in files.items():
        rows = [r for r in read_results(path) if r["method"] in methods and r["task"] in tasks]
        summary = summarise([r for r in rows if "score" in r])["settings"].get("standard, K=1")
        for m in methods:
            if summary and m in summary:
                config = next((r.get("config") for r in rows if r["method"] == m), None)
                points[m].append(curve_point(scale, spec, summary[m], config))
    settings = {
        "budget": args.budget,
        "scales": list(files),
        "draws": args.draws,
        "episodes": args.episodes,
        "k": 1,
        "results": [str(path) for _, path in files.values()],
    }
    return build_curve(args.domain, tasks, settings, points)


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--methods", required=True, help="baselines, a comma list (e.g. bc,td3il)")
    p.add_argument("--tasks", required=True, help="tasks, a comma list")
    p.add_argument("--scales", default="0.25,0.5,1,2", help="step multipliers, a comma list")
    p.add_argument("--budget", default="cpu", help="the named budget to scale")
    p.add_argument("--domain", default="point_mass_maze")
    p.add_argument("--demos", required=True, help="folder of <task>.npz demo files")
    p.add_argument("--data", default=None, help="unsupervised dataset (all baselines but bc)")
    p.add_argument("--draws", type=int, default=2, help="demo draws per task")
    p.add_argument("--episodes", type=int, default=20, help="evaluation episodes per job")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--workers", type=int, default=1, help="jobs run in parallel")
    p.add_argument("--threads", type=int, default=1, help="torch threads per worker")
    p.add_argument("--out", required=True, help="folder for results files and the curve")
    p.add_argument(
        "--reuse", default=None,
        help="a results file whose matching jobs (same job, same data_digest) count",
    )  # fmt: skip
    p.add_argument(
        "--no-run", action="store_true",
        help="run no job: write the curve from the lines already in OUT's results files",
    )  # fmt: skip
    p.add_argument(
        "--merge", default=None,
        help="a budget_curve.json whose other methods' entries the new curve keeps",
    )  # fmt: skip
    return p.parse_args(argv)


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    try:
        scales = _scales(args.scales)
        merged = read_curve(args.merge) if args.merge else None
        if merged:  # refuse an unmergeable curve before hours of jobs, not after
            settings = {"budget": args.budget, "draws": args.draws, "episodes": args.episodes}
            merge_curves(merged, {"domain": args.domain, "k": 1, **settings, "methods": {}})
        files = run_grids(args, scales)
        curve = curve_from_results(args, files)
        if not any(e["points"] for e in curve["methods"].values()):
            raise FbilError(f"no finished jobs of {args.methods} in {args.out}'s results files")
        json_path, png = write_curve(merge_curves(merged, curve) if merged else curve, args.out)
    except FbilError as exc:
        print(f"budget_curve: error: {exc}", file=sys.stderr)
        return 2
    print(f"curve: {json_path}\nfigure: {png}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
