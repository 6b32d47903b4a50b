"""The report's views by family and IL principle (the paper's Figs. 1 and 3) and of time
to policy (Fig. 2), from `report.summarise`'s per-method summaries of one setting.

A group's score is the mean over its methods of each method's score (itself the mean over
tasks and draws), so every method weighs the same, as in the paper's figures. The paper's
value beside it is the same mean over the same methods, from their domain mean scores
(Tables 5-7); the paper's own figures average over its full set of methods, whose values
its text does not state.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from fbil.evaluation.paper import (
    PAPER_SCORES,
    PAPER_TIMES,
    PRINCIPLE_CLASSES,
    paper_seconds,
    principle_class,
)
from fbil.imitators import FAMILIES, imitators

ALL = "all principles"
COLOURS = ("tab:blue", "tab:orange", "tab:green")  # by position in FAMILIES


def _colour(family: str) -> str:
    return COLOURS[FAMILIES.index(family)] if family in FAMILIES else "tab:gray"


def order(methods: Iterable[str]) -> list[str]:
    """Registry order (FB-IL's main methods, the others, then the baselines), then any
    name no longer registered."""
    found = set(methods)
    known = [m for m in imitators() if m in found]
    return known + sorted(found - set(known))


def _nan_mean(values: Iterable[float]) -> float:
    kept = [v for v in values if not math.isnan(v)]
    return float(np.mean(kept)) if kept else float("nan")


def _fmt(x: float) -> str:
    return "–" if math.isnan(x) else f"{x:.1f}"


def _family_order(families: Iterable[str]) -> list[str]:
    found = set(families)
    return [f for f in FAMILIES if f in found] + sorted(found - set(FAMILIES))


def _class_order(classes: Iterable[str]) -> list[str]:
    known = list(dict.fromkeys(c for _, c in PRINCIPLE_CLASSES))
    found = set(classes)
    return [c for c in known if c in found] + sorted(found - set(known))


def groups(methods: dict[str, Any], domain: str) -> dict[tuple[str, str], dict[str, Any]]:
    """(family, the paper's principle class or ALL) -> its methods, our mean score (%) and
    the paper's over those of its methods that the paper reports."""
    members: dict[tuple[str, str], list[str]] = {}
    for name, summary in methods.items():
        family = summary["family"]
        for key in ((family, principle_class(summary["principle"])), (family, ALL)):
            members.setdefault(key, []).append(name)
    paper = PAPER_SCORES.get(domain, {})
    return {
        key: {
            "methods": order(names),
            "score": _nan_mean(100 * methods[m]["score"] for m in names),
            "paper": _nan_mean(paper[m] for m in names if m in paper),
            "paper_methods": sum(m in paper for m in names),
        }
        for key, names in members.items()
    }


def _ordered_keys(keys: Iterable[tuple[str, str]]) -> list[tuple[str, str]]:
    keys = list(keys)
    classes = [*_class_order(c for _, c in keys if c != ALL), ALL]
    return [
        (f, c) for f in _family_order(f for f, _ in keys) for c in classes if (f, c) in set(keys)
    ]


def groups_table(cells: dict[tuple[str, str], dict[str, Any]]) -> list[str]:
    lines = [
        "| family | IL principle | methods | score (%) | paper (%, same methods) |",
        "|---|---|---|---|---|",
    ]
    for family, cls in _ordered_keys(cells):
        cell = cells[(family, cls)]
        covered = len(cell["methods"]) - cell["paper_methods"]
        note = f" ({cell['paper_methods']} of {len(cell['methods'])})" if covered else ""
        bold = "**" if cls == ALL else ""
        lines.append(
            f"| {bold}{family}{bold} | {bold}{cls}{bold} | {', '.join(cell['methods'])} | "
            f"{bold}{_fmt(cell['score'])}{bold} | {_fmt(cell['paper'])}{note} |"
        )
    return lines


def groups_figure(cells: dict[tuple[str, str], dict[str, Any]], title: str, out: Path) -> Path:
    """Bars of our score per principle class (x) and family (colour); the paper's value of
    the same methods as a black tick on each bar."""
    from fbil.envs.render import _pyplot, _save

    plt = _pyplot()
    keys = _ordered_keys(cells)
    families = _family_order(f for f, _ in keys)
    classes = [*_class_order(c for _, c in keys if c != ALL), ALL]
    width = 0.8 / len(families)
    fig, ax = plt.subplots(figsize=(1.5 + 1.3 * len(classes), 3.2), dpi=120)
    for i, family in enumerate(families):
        xs = [j + (i - (len(families) - 1) / 2) * width for j, c in enumerate(classes)]
        here = [
            (x, cells[(family, c)])
            for x, c in zip(xs, classes, strict=True)
            if (family, c) in cells
        ]
        scores = [c["score"] for _, c in here]
        ax.bar([x for x, _ in here], scores, width, color=_colour(family), label=family)
        ax.plot([x for x, _ in here], [c["paper"] for _, c in here], "k_", ms=14, mew=2)
    ax.plot([], [], "k_", ms=10, mew=2, label="paper (same methods)")
    ax.set_xticks(range(len(classes)), classes, fontsize=7)
    ax.set_ylabel("imitation score (%)")
    ax.set_title(title, fontsize=9)
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))  # off the bars
    return _save(fig, out)


def duration(seconds: float) -> str:
    """A time in the unit that suits it: ms below a second, minutes past two, hours past two
    hours (the paper's Fig. 2 puts baselines in hours and FB-IL in seconds)."""
    steps = ((1.0, 1e-3, "ms"), (120.0, 1.0, "s"), (7200.0, 60.0, "min"))
    for below, unit, name in steps:
        if seconds < below:
            return f"{seconds / unit:.3g} {name}"
    return f"{seconds / 3600:.3g} h"


def time_table(methods: dict[str, Any], names: Sequence[str]) -> list[str]:
    lines = [
        "| method | family | fbil, CPU: median | median (s) | jobs | paper, GPU (Table 8) |",
        "|---|---|---|---|---|---|",
    ]
    for m in names:
        r = methods[m]
        lines.append(
            f"| {m} | {r['family']} | {duration(r['seconds_median'])} | "
            f"{r['seconds_median']:.4g} | {r['jobs']} | {PAPER_TIMES.get(m, '–')} |"
        )
    return lines


def time_figure(methods: dict[str, Any], names: Sequence[str], title: str, out: Path) -> Path:
    """Median time to policy per method on a log scale, coloured by family; the paper's
    Table 8 time as a black diamond (a triangle for its '< 5 s' upper bounds)."""
    from matplotlib.patches import Patch

    from fbil.envs.render import _pyplot, _save

    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(1.2 + 0.55 * len(names), 3.4), dpi=120)
    families = [methods[m]["family"] for m in names]
    colours = [_colour(f) for f in families]
    ax.bar(range(len(names)), [methods[m]["seconds_median"] for m in names], color=colours)
    for i, m in enumerate(names):
        if m in PAPER_TIMES:
            seconds, bound = paper_seconds(PAPER_TIMES[m])
            ax.plot(i, seconds, "kv" if bound else "kD", ms=5)
    handles = [Patch(color=_colour(f), label=f) for f in _family_order(families)]
    handles += ax.plot([], [], "kD", ms=5, label="paper, GPU (Table 8)")
    handles += ax.plot([], [], "kv", ms=5, label="paper: under this")
    ax.set_yscale("log")
    ax.set_xticks(range(len(names)), names, rotation=60, fontsize=7)
    ax.set_ylabel("time to policy (s, median over jobs)")
    ax.set_title(title, fontsize=9)
    ax.legend(handles=handles, fontsize=6)
    return _save(fig, out)


def over_domains(per_domain: dict[str, dict[tuple[str, str], dict[str, Any]]]) -> list[str]:
    """Each group's score per domain and its mean over the domains that have it, ours
    (paper's for the same methods)."""
    domains = list(per_domain)
    keys = _ordered_keys({k for cells in per_domain.values() for k in cells})
    lines = [
        "| family | IL principle | " + " | ".join(domains) + " | mean over domains |",
        "|---|---|" + "---|" * (len(domains) + 1),
    ]
    for key in keys:
        present = [per_domain[d][key] for d in domains if key in per_domain[d]]
        cells = [
            f"{_fmt(per_domain[d][key]['score'])} ({_fmt(per_domain[d][key]['paper'])})"
            if key in per_domain[d]
            else "–"
            for d in domains
        ]
        mean = _nan_mean(c["score"] for c in present)
        paper = _nan_mean(c["paper"] for c in present)
        bold = "**" if key[1] == ALL else ""
        lines.append(
            f"| {bold}{key[0]}{bold} | {bold}{key[1]}{bold} | " + " | ".join(cells) + " | "
            f"{bold}{_fmt(mean)}{bold} ({_fmt(paper)}) over {len(present)} |"
        )
    return lines


def mean_over_domains(
    per_domain: dict[str, dict[tuple[str, str], dict[str, Any]]],
) -> dict[tuple[str, str], dict[str, Any]]:
    """The groups averaged over domains (what `groups_figure` draws for Fig. 1)."""
    keys = {k for cells in per_domain.values() for k in cells}
    out = {}
    for key in keys:
        present = [cells[key] for cells in per_domain.values() if key in cells]
        out[key] = {
            "methods": sorted({m for c in present for m in c["methods"]}),
            "score": _nan_mean(c["score"] for c in present),
            "paper": _nan_mean(c["paper"] for c in present),
            "paper_methods": max(c["paper_methods"] for c in present),
        }
    return out
