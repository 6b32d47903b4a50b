"""Side by side: several FB models (recipes, fine-tunes, checkpoints) on the same grid.

Each `--run NAME=RESULTS[,ZERO_SHOT]` names the results file of `fbil benchmark --model M ...`
for one model and, optionally, the `--json` output of `fbil zero-shot M ...`. Several models
of one recipe (seeds) join with `+` on both sides (`a.jsonl+b.jsonl,a_zs.json+b_zs.json`):
their lines are pooled, so with the same grid each the score is the mean over seeds, and the
zero-shot return of each task is the mean over the files. Prints, per
model, the mean imitation score (%) of each method and of all methods, the zero-shot
returns, and the mean return per task of the methods in --per-task; writes them with --out.
Lines are kept only for the demo draws in --draws, the tasks in --tasks and the methods in
--methods (all by default), so models evaluated on different grids can be compared on the
jobs they share.

Usage: python scripts/compare_models.py --run A=runs/a.jsonl,runs/a_zs.json --run B=... \
           [--draws 0,1] [--tasks t1,t2] [--methods m1,m2] [--per-task erfb,goalfb]
           [--out FILE.json] [--plot FILE.png]
           [--curve training_curve.json --domain D [--committed NAME] [--note TEXT]]

With --plot, every NAME is a number (e.g. the model's FB updates: `--run 100000=...`), and
the figure shows each method's score, their mean and the zero-shot mean against it: a
training-length curve of imitation, as `scripts/zero_shot_curve.py` draws zero-shot's.
With --curve FILE --domain D (numeric NAMEs too), the same comparison is written as the
`training_curve.json` that `fbil report` shows next to D's results; --committed NAME marks
the snapshot that is the committed model, --note adds a sentence.
"""

from __future__ import annotations

import argparse
import gzip
import json
import shlex
import statistics
import sys
from pathlib import Path
from typing import Any

from fbil.checkpoint import atomic_write_text
from fbil.errors import FbilError
from fbil.evaluation.training_curve import curve_points, plot_training_curve


def summarise(
    results: Path | list[Path],
    draws: set[int] | None,
    per_task: list[str],
    tasks: set[str] | None = None,
    methods: set[str] | None = None,
) -> dict[str, Any]:
    """Mean score (%) per method and overall, mean return per (method in per_task, task), over
    the lines of the chosen draws, tasks and methods (None: all)."""
    files = results if isinstance(results, list) else [results]
    kept = [
        [
            r
            for r in _read_lines(path)
            if (draws is None or r["draw"] in draws)
            and (tasks is None or r["task"] in tasks)
            and (methods is None or r["method"] in methods)
        ]
        for path in files
    ]
    names = "+".join(str(f) for f in files)
    if len({len(k) for k in kept}) > 1:  # pooled lines average the seeds only if equal in number
        sizes = ", ".join(str(len(k)) for k in kept)
        raise FbilError(f"{names}: the pooled files keep {sizes} lines; give each the same grid")
    rows = [r for k in kept for r in k]
    if not rows:
        raise FbilError(f"{names}: no results lines for the chosen draws, tasks and methods")
    methods = sorted({r["method"] for r in rows})
    score = {
        m: 100 * statistics.mean(r["score"] for r in rows if r["method"] == m) for m in methods
    }
    score["mean"] = 100 * statistics.mean(r["score"] for r in rows)
    tasks = sorted({r["task"] for r in rows})
    returns = {
        m: {
            t: statistics.mean(
                r["return_mean"] for r in rows if r["method"] == m and r["task"] == t
            )
            for t in tasks
        }
        for m in per_task
        if m in methods
    }
    return {"jobs": len(rows), "score_pct": score, "returns": returns}


def _read_lines(path: Path) -> list[dict[str, Any]]:
    """The results lines of a .jsonl file, or of a gzipped one (.jsonl.gz, as committed)."""
    try:
        if path.suffix == ".gz":
            text = gzip.decompress(path.read_bytes()).decode()
        else:
            text = path.read_text()
        return [json.loads(line) for line in text.splitlines() if line.strip()]
    except (OSError, EOFError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise FbilError(f"{path}: cannot read results lines ({exc})") from None


def zero_shot_mean(files: list[Path]) -> dict[str, float]:
    """Per task, the mean over the `fbil zero-shot --json` files of their mean return; the
    files must cover the same tasks."""
    per_file = []
    for path in files:
        try:
            zs = json.loads(path.read_text())
            per_file.append({t: float(v["return_mean"]) for t, v in zs["tasks"].items()})
        except (OSError, ValueError, KeyError, TypeError, AttributeError) as exc:
            raise FbilError(f"{path}: not a `fbil zero-shot --json` output ({exc})") from None
    if any(set(f) != set(per_file[0]) for f in per_file):
        raise FbilError(
            "the zero-shot files of one --run cover different tasks; use the same --tasks"
        )
    return {t: statistics.mean(f[t] for f in per_file) for t in per_file[0]}


def print_table(title: str, columns: dict[str, dict[str, float]]) -> None:
    """One column per model, one row per key any model has ("mean" last); nothing if empty."""
    keys = sorted({k for col in columns.values() for k in col} - {"mean"})
    keys += ["mean"] if any("mean" in col for col in columns.values()) else []
    if not keys:
        return
    print(title.ljust(26) + "".join(n[:14].rjust(15) for n in columns))
    for k in keys:
        print(
            f"  {k:24s}" + "".join(f"{col.get(k, float('nan')):15.1f}" for col in columns.values())
        )


def _write_curve(args: argparse.Namespace, out: dict[str, Any], argv: list[str] | None) -> None:
    """The report's training_curve.json (fbil.evaluation.training_curve) from the runs."""
    if not args.domain:
        raise FbilError("--curve needs --domain (the runs' domain, e.g. walker)")
    curve_points(out)  # numeric names, or a one-line error
    if args.committed is not None and args.committed not in out:
        raise FbilError(f"--committed {args.committed!r} is not one of the --run names")
    words = sys.argv[1:] if argv is None else argv
    curve = {
        "domain": args.domain,
        "committed": args.committed,
        "command": "python scripts/compare_models.py " + shlex.join(words),
        "note": args.note,
        "runs": out,
    }
    atomic_write_text(Path(args.curve), json.dumps(curve, indent=1) + "\n")


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--run", action="append", required=True, metavar="NAME=RESULTS[,ZERO_SHOT]")
    p.add_argument("--draws", default="", help="comma list of demo draws to keep (all)")
    p.add_argument("--tasks", default="", help="comma list of tasks to keep (all)")
    p.add_argument("--methods", default="", help="comma list of methods to keep (all)")
    p.add_argument(
        "--per-task", default="erfb,goalfb", help="methods whose per-task returns to show"
    )
    p.add_argument("--out", default=None, help="write the comparison here (.json)")
    p.add_argument("--plot", default=None, help="draw the scores against numeric NAMEs (.png)")
    p.add_argument("--curve", default=None, help="write a report's training_curve.json here")
    p.add_argument("--domain", default=None, help="the runs' domain (needed by --curve)")
    p.add_argument("--committed", default=None, help="--curve: NAME of the committed model")
    p.add_argument("--note", default="", help="--curve: a sentence for the report")
    args = p.parse_args(argv)
    try:
        draws = {int(d) for d in args.draws.split(",") if d.strip()} or None
        per_task = [m.strip() for m in args.per_task.split(",") if m.strip()]
        tasks = {t.strip() for t in args.tasks.split(",") if t.strip()} or None
        methods = {m.strip() for m in args.methods.split(",") if m.strip()} or None
        out: dict[str, Any] = {}
        for run in args.run:
            name, sep, files = run.partition("=")
            if not sep or not name or not files:
                raise FbilError(f"--run {run!r}: give NAME=RESULTS[,ZERO_SHOT]")
            results, _, zero_shot = files.partition(",")
            paths = [Path(f) for f in results.split("+")]
            entry = summarise(paths, draws, per_task, tasks, methods)
            if zero_shot:
                entry["zero_shot"] = zero_shot_mean([Path(f) for f in zero_shot.split("+")])
            out[name] = entry
        if args.plot:
            plot_training_curve(out, Path(args.plot))
        if args.curve:
            _write_curve(args, out, argv)
    except (FbilError, ValueError, KeyError, OSError) as exc:
        print(f"compare_models: error: {exc}", file=sys.stderr)
        return 2
    print_table("score %", {n: e["score_pct"] for n, e in out.items()})
    print_table("zero-shot return", {n: e.get("zero_shot", {}) for n, e in out.items()})
    for m in per_task:
        print_table(f"{m} return", {n: e["returns"].get(m, {}) for n, e in out.items()})
    if args.out:
        atomic_write_text(Path(args.out), json.dumps(out, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
