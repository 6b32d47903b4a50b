"""Imitation against training length: one run's snapshots, each with its own K = 1 grid and
zero-shot check, side by side (`scripts/compare_models.py --curve`).

A `training_curve.json` next to a domain's results adds its section to `fbil report`: the
evidence that tells "more updates would help" from "this recipe has flattened". Its shape:
{"domain", "committed" (the snapshot name of the committed model, or null), "command",
"note", "runs": {"<FB updates>": {"jobs", "score_pct": {method: %, "mean": %},
"zero_shot": {task: return}}}}.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

from fbil.errors import FbilError
from fbil.evaluation.sidecar import find_sidecar

TRAINING_CURVE_FILE = "training_curve.json"


def curve_points(runs: dict[str, dict[str, Any]]) -> list[tuple[float, str]]:
    """(FB updates, name) for every run, in order; names must be numbers."""
    try:
        return sorted((float(name), name) for name in runs)
    except ValueError:
        raise FbilError(
            "a training curve needs numeric run names (the snapshot's FB updates, e.g. 100000)"
        ) from None


def plot_training_curve(runs: dict[str, dict[str, Any]], path: Path, title: str = "") -> Path:
    """Score (%) per method and their mean, and the zero-shot mean (right axis), against
    the runs' FB updates."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    points = curve_points(runs)
    xs = [x for x, _ in points]
    fig, ax = plt.subplots(figsize=(6.4, 3.8))
    methods = sorted({m for e in runs.values() for m in e["score_pct"]} - {"mean"})
    for m in methods:
        ys = [runs[n]["score_pct"].get(m, float("nan")) for _, n in points]
        ax.plot(xs, ys, ".-", lw=0.8, alpha=0.6, label=m)
    ax.plot(xs, [runs[n]["score_pct"]["mean"] for _, n in points], "ko-", lw=2.2, label="mean")
    ax.set_xlabel("FB updates")
    ax.set_ylabel("imitation score (%), K = 1")
    ax.grid(alpha=0.3)
    if title:
        ax.set_title(title, fontsize=9)
    zs = [(x, _mean(z)) for x, n in points if (z := runs[n].get("zero_shot"))]
    if zs:
        twin = ax.twinx()
        twin.plot([x for x, _ in zs], [y for _, y in zs], "s--", color="grey")
        twin.plot([], [], "s--", color="grey", label="zero-shot mean (right)")
        twin.set_ylabel("zero-shot mean return (z_r)")
        twin.set_ylim(0, 1000)  # a task's return is at most 1 000
        twin.legend(fontsize=7, loc="lower right")
    ax.legend(fontsize=7, ncol=2, loc="upper left")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def _mean(values: dict[str, float]) -> float:
    return sum(values.values()) / len(values)


def find_training_curve(files: Sequence[str | Path], domain: str) -> dict[str, Any] | None:
    """The training_curve.json next to one of the results files, if it is of `domain`."""
    curve = find_sidecar(
        files, TRAINING_CURVE_FILE, domain, "rerun scripts/compare_models.py --curve"
    )
    if curve is not None and not isinstance(curve.get("runs"), dict):
        raise FbilError(
            f"{TRAINING_CURVE_FILE} of {domain} has no 'runs'; rerun scripts/compare_models.py "
            "--curve"
        )
    return curve


def training_curve_section(curve: dict[str, Any], out_dir: Path) -> list[str]:
    """The report's part on training length: score per method (rows) at each snapshot
    (columns), the zero-shot mean, and the figure."""
    runs: dict[str, dict[str, Any]] = curve["runs"]
    points = curve_points(runs)
    committed = curve.get("committed")
    heads = [f"{int(x):,}" + (" (committed)" if n == committed else "") for x, n in points]
    methods = sorted({m for e in runs.values() for m in e["score_pct"]} - {"mean"})
    lines = [
        "## Imitation against training length (standard, K=1)",
        "",
        "One FB run's snapshots, each with its own standard K=1 grid and zero-shot check "
        "(`scripts/compare_models.py --curve`). A curve still rising says more updates would "
        "help; a flat or falling one, that the recipe, not the length, bounds the scores."
        + (f" {curve['note']}" if curve.get("note") else ""),
        "",
        "| score (%) | " + " | ".join(heads) + " |",
        "|---|" + "---|" * len(heads),
    ]
    for m in [*methods, "mean"]:
        cells = [runs[n]["score_pct"].get(m) for _, n in points]
        name = "**mean**" if m == "mean" else m
        lines.append(f"| {name} | " + " | ".join(_cell(c) for c in cells) + " |")
    zs = [runs[n].get("zero_shot") for _, n in points]
    if any(zs):
        lines.append(
            "| zero-shot mean return | "
            + " | ".join(_cell(_mean(z) if z else None) for z in zs)
            + " |"
        )
    fig = plot_training_curve(runs, out_dir / "training_curve.png", curve["domain"])
    lines += ["", f"![training curve]({fig.name})", ""]
    if curve.get("command"):
        lines += [f"Command: `{curve['command']}`", ""]
    return lines


def _cell(x: float | None) -> str:
    return "–" if x is None else f"{x:.1f}"
