"""The time-to-policy table measured in one run on one machine: the output of
`benchmarks/time_to_policy.py --baselines ... --json`, saved as `time_to_policy.json` next to
a domain's results. The grids' own times come from different runs (and, across sessions,
different machines); this table is the like-for-like comparison #22 asks for."""

from __future__ import annotations

import statistics
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from fbil.evaluation.families import duration
from fbil.evaluation.paper import PAPER_TIMES
from fbil.evaluation.sidecar import find_sidecar

TIMING_FILE = "time_to_policy.json"


def find_timing(files: Sequence[str | Path], domain: str) -> dict[str, Any] | None:
    """The time_to_policy.json next to one of the results files, if it is of `domain`."""
    remedy = "rerun benchmarks/time_to_policy.py --json"
    return find_sidecar(files, TIMING_FILE, domain, remedy)


def timing_section(timing: dict[str, Any]) -> list[str]:
    """Each FB-IL method's median and each baseline's projected time, with its ratio to the
    FB-IL methods' median, from one run."""
    fb = timing.get("methods", {})
    baselines = timing.get("baselines", {})
    if not fb or not baselines:
        return []
    fb_median = statistics.median(float(r["median_seconds"]) for r in fb.values())
    scales = ", ".join(next(iter(baselines.values()))["median_seconds"])
    lines = [
        "### Time to policy, measured in one run on one machine",
        "",
        f"`{timing.get('command', 'benchmarks/time_to_policy.py')}` on {timing.get('machine')} "
        f"with {timing.get('threads')} thread(s), one demonstration of "
        f"{timing.get('demo_steps')} steps. FB-IL: median of {timing.get('repeats')} calls. "
        f"Baselines: median of {timing.get('baseline_repeats')} fits at each of the scales "
        f"{scales} of the budget, projected to the full budget through a line (time is "
        "linear in the gradient steps, plus fixed work).",
        "",
        "| method | family | time to policy | seconds | × FB-IL median | paper, GPU (Table 8) |",
        "|---|---|---|---|---|---|",
    ]
    for m, r in fb.items():
        s = float(r["median_seconds"])
        lines.append(
            f"| {m} | fb-il | {duration(s)} | {s:.4g} | {s / fb_median:.2g} | "
            f"{PAPER_TIMES.get(m, '–')} |"
        )
    for m, r in sorted(baselines.items(), key=lambda kv: kv[1]["projected_seconds"]):
        s = float(r["projected_seconds"])
        lines.append(
            f"| {m} ({r['budget']}) | offline-il | {duration(s)} | {s:.4g} | "
            f"{s / fb_median:,.0f} | {PAPER_TIMES.get(m, '–')} |"
        )
    return [*lines, ""]
