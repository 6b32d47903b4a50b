"""`fbil report`'s views by family and IL principle (the paper's Figs. 1 and 3), the
baselines' per-task returns next to the paper's, time to policy (Fig. 2) and the report
over domains, on synthetic results lines: no training, no rollouts."""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import pytest

from fbil.errors import FbilError
from fbil.evaluation.families import groups
from fbil.evaluation.paper import PAPER_SCORES
from fbil.evaluation.report import summarise, write_report
from fbil.imitators import family_of, principle_of

EXPERT = 200.0


def _rows(
    domain: str, method: str, scores: dict[str, Sequence[float]], seconds: Sequence[float]
) -> list[dict[str, Any]]:
    """One results line per (task, draw), as `fbil benchmark` writes them (the fields the
    report reads); `seconds` is consumed in order over the jobs."""
    times = iter(seconds)
    return [
        {
            "model": None,
            "demos": f"nowhere/{task}.npz",
            "domain": domain,
            "task": task,
            "demo_set": "standard",
            "method": method,
            "draw": draw,
            "k": 1,
            "episodes": 2,
            "seed": 0,
            "budget": "cpu" if family_of(method) == "offline-il" else None,
            "expert_return": EXPERT,
            "commit": "0123456789abcdef",
            "family": family_of(method),
            "principle": principle_of(method),
            "return_mean": score * EXPERT,
            "score": score,
            "seconds": next(times),
        }
        for task, per_draw in scores.items()
        for draw, score in enumerate(per_draw)
    ]


def _write(path: Path, rows: list[dict[str, Any]]) -> Path:
    path.write_text("".join(json.dumps(r) + "\n" for r in rows))
    return path


# Maze: two tasks x two draws per method; each method's mean score is round.
MAZE = {
    "erfb": ({"loop": (0.4, 0.6), "square": (0.5, 0.5)}, (0.002, 0.003, 0.004, 0.1)),  # 50 %
    "rerfb": ({"loop": (0.7, 0.7), "square": (0.7, 0.7)}, (0.01,) * 4),  # 70 %
    "bcfb": ({"loop": (0.2, 0.2), "square": (0.4, 0.4)}, (30.0,) * 4),  # 30 %
    "sqil": ({"loop": (0.9, 0.7), "square": (0.8, 0.8)}, (600.0, 900.0, 1200.0, 3e4)),  # 80 %
    "td3il": ({"loop": (0.6, 0.6), "square": (0.6, 0.6)}, (800.0,) * 4),  # 60 %
    "goal_td3": ({"loop": (0.9, 0.9), "square": (0.9, 0.9)}, (0.001,) * 4),  # 90 %
}


def _maze_rows() -> list[dict[str, Any]]:
    return [r for m, (s, t) in MAZE.items() for r in _rows("point_mass_maze", m, s, t)]


def test_family_and_principle_means_average_methods_over_tasks_and_draws() -> None:
    summary = summarise(_maze_rows())
    cells = groups(summary["settings"]["standard, K=1"], "point_mass_maze")
    paper = PAPER_SCORES["point_mass_maze"]
    reward = cells[("fb-il", "reward")]
    assert reward["methods"] == ["erfb", "rerfb"]
    assert reward["score"] == pytest.approx(60.0)  # (50 + 70) / 2
    assert reward["paper"] == pytest.approx((paper["erfb"] + paper["rerfb"]) / 2)
    assert cells[("fb-il", "all principles")]["score"] == pytest.approx(50.0)  # 50, 70, 30
    assert cells[("fb-il", "BC")]["score"] == pytest.approx(30.0)
    assert cells[("offline-il", "reward")]["score"] == pytest.approx(70.0)  # sqil 80, td3il 60
    assert cells[("bfm", "goal-based")]["paper"] == pytest.approx(paper["goal_td3"])
    assert set(cells) == {
        ("fb-il", "reward"),
        ("fb-il", "BC"),
        ("fb-il", "all principles"),
        ("offline-il", "reward"),
        ("offline-il", "all principles"),
        ("bfm", "goal-based"),
        ("bfm", "all principles"),
    }


def test_domain_report_shows_families_baseline_returns_and_times(tmp_path: Path) -> None:
    results = _write(tmp_path / "maze.jsonl", _maze_rows())
    text = write_report(results, tmp_path / "report").read_text()
    paper = PAPER_SCORES["point_mass_maze"]
    # (a) the family / principle table, with the paper's mean of the same methods.
    reward = (paper["erfb"] + paper["rerfb"]) / 2
    assert f"| fb-il | reward | erfb, rerfb | 60.0 | {reward:.1f} |" in text
    assert "| **fb-il** | **all principles** | erfb, rerfb, bcfb | **50.0** |" in text
    assert (tmp_path / "report" / "families.png").stat().st_size > 1000
    # (b) a baseline's per-task returns next to Table 5's (loop 741.0, square 694.5).
    assert f"| sqil | {0.8 * EXPERT:.1f} (741.0) | {0.8 * EXPERT:.1f} (694.5) |" in text
    assert f"| td3il | {0.6 * EXPERT:.1f} (752.2) | {0.6 * EXPERT:.1f} (244.3) |" in text
    # (c) medians over jobs in a readable unit, with Table 8 beside; the log-scale figure.
    assert "| sqil | offline-il | 17.5 min | 1050 | 4 | 10h18m |" in text
    assert "| erfb | fb-il | 3.5 ms | 0.0035 | 4 | <5s |" in text
    assert "| bcfb | fb-il | 30 s | 30 | 4 | 1m |" in text
    assert (tmp_path / "report" / "time_to_policy.png").stat().st_size > 1000
    assert "## Over domains" not in text
    # (d) the score table gives the same medians in the same units.
    assert "| bcfb | behavioral cloning | 30.0 | 0.0 | 2 | 76.5 | 30 s |" in text
    assert text.count("| 17.5 min |") == 2 and text.count("| 3.5 ms |") == 2


def test_one_run_timing_next_to_the_results_adds_its_table(tmp_path: Path) -> None:
    """A time_to_policy.json of the domain (benchmarks/time_to_policy.py --baselines --json)
    adds the like-for-like table: FB-IL medians and baselines' projections, with their
    ratio to the FB-IL median; one of another domain, or none, adds nothing."""
    results = _write(tmp_path / "maze.jsonl", _maze_rows())
    timing = {
        "command": "python benchmarks/time_to_policy.py --baselines bc,sqil",
        "domain": "point_mass_maze",
        "machine": "CPU X, AVX2",
        "threads": 1,
        "repeats": 10,
        "baseline_repeats": 3,
        "demo_steps": 1000,
        "methods": {"erfb": {"median_seconds": 0.004}, "bcfb": {"median_seconds": 0.016}},
        "baselines": {
            "sqil": {
                "budget": "cpu",
                "median_seconds": {"0.01": 9.0, "0.02": 18.0},
                "fixed_seconds": 0.0,
                "projected_seconds": 900.0,
            },
            "bc": {
                "budget": "cpu",
                "median_seconds": {"0.01": 1.0, "0.02": 2.0},
                "fixed_seconds": 0.0,
                "projected_seconds": 100.0,
            },
        },
    }
    plain = write_report(results, tmp_path / "r0").read_text()
    assert "measured in one run" not in plain
    (tmp_path / "time_to_policy.json").write_text(json.dumps(timing))
    text = write_report(results, tmp_path / "r1").read_text()
    assert "### Time to policy, measured in one run on one machine" in text
    assert "on CPU X, AVX2 with 1 thread(s)" in text and "scales 0.01, 0.02" in text
    # FB-IL median 0.01 s: erfb 0.4 x, bc 10 000 x, sqil 90 000 x, fastest baseline first.
    assert "| erfb | fb-il | 4 ms | 0.004 | 0.4 | <5s |" in text
    assert text.index("| bc (cpu) |") < text.index("| sqil (cpu) |")
    assert "| bc (cpu) | offline-il | 100 s | 100 | 10,000 | 3h14m |" in text
    assert "| sqil (cpu) | offline-il | 15 min | 900 | 90,000 | 10h18m |" in text
    (tmp_path / "time_to_policy.json").write_text(json.dumps({**timing, "domain": "walker"}))
    assert "measured in one run" not in write_report(results, tmp_path / "r2").read_text()
    (tmp_path / "time_to_policy.json").write_text("{not json")
    with pytest.raises(FbilError, match=r"time_to_policy\.json is not valid JSON"):
        write_report(results, tmp_path / "r3")


def test_a_method_trained_on_two_regenerations_of_its_data_is_flagged(tmp_path: Path) -> None:
    rows = _maze_rows()
    for i, r in enumerate(rows):
        if r["method"] in ("sqil", "td3il"):
            # sqil: its first two jobs on one regeneration, the last two on another.
            same = r["method"] == "td3il" or i % 4 < 2
            r.update(data_digest="aaaa" if same else "bbbb", machine=f"CPU {i % 2}, AVX2")
    text = write_report(_write(tmp_path / "maze.jsonl", rows), tmp_path / "report").read_text()
    assert "Machines: CPU 0, AVX2; CPU 1, AVX2 (16 of 24 lines, older ones, record none)." in text
    assert "sqil's lines were trained on 2 different datasets (data_digest aaaa, bbbb)" in text
    assert "td3il's lines were" not in text
    # Lines without the fields (before session 24) add nothing.
    plain = write_report(_write(tmp_path / "m.jsonl", _maze_rows()), tmp_path / "r").read_text()
    assert "Machines:" not in plain and "different datasets" not in plain


def test_results_of_several_domains_add_a_report_over_domains(tmp_path: Path) -> None:
    walker = {
        "erfb": ({"run": (0.3, 0.3), "walk": (0.3, 0.3)}, (0.01,) * 4),  # 30 %
        "td3il": ({"run": (0.5, 0.5), "walk": (0.5, 0.5)}, (900.0,) * 4),  # 50 %
    }
    walker_rows = [r for m, (s, t) in walker.items() for r in _rows("walker", m, s, t)]
    files = [
        _write(tmp_path / "maze.jsonl", _maze_rows()),
        _write(tmp_path / "walker.jsonl", walker_rows),
    ]
    report = write_report(files, tmp_path / "report")
    text = report.read_text()
    assert report == tmp_path / "report" / "report.md"
    assert "## Over domains" in text and "[walker](walker/report.md)" in text
    # fb-il over both: maze 50 (erfb, rerfb, bcfb), walker 30 (erfb) -> 40.
    maze = PAPER_SCORES["point_mass_maze"]
    paper_maze = (maze["erfb"] + maze["rerfb"] + maze["bcfb"]) / 3
    paper = (paper_maze + PAPER_SCORES["walker"]["erfb"]) / 2
    line = next(x for x in text.splitlines() if x.startswith("| **fb-il** | **all principles**"))
    assert f"| **40.0** ({paper:.1f}) over 2 |" in line
    assert "| td3il | offline-il | 13.3 min | 15 min | 7h3m |" in text  # 800 s, 900 s
    for domain in ("point_mass_maze", "walker"):
        assert (
            "# fbil benchmark report: " + domain
            in (report.parent / domain / "report.md").read_text()
        )
        assert (report.parent / domain / "time_to_policy.png").is_file()
    assert (report.parent / "families_over_domains.png").stat().st_size > 1000


def test_a_method_has_one_budget_per_domain_and_may_have_another_elsewhere(
    tmp_path: Path,
) -> None:
    """Within a domain a method's lines must share one budget, across files too; between
    domains they may differ (walker's TD3 baselines train 5x maze's), and the time table
    over domains then names each budget."""
    walker_rows = _rows("walker", "td3il", {"run": (0.5, 0.5)}, (1500.0, 1600.0))
    for r in walker_rows:
        r["budget"] = "cpu@5"
    maze = _write(tmp_path / "maze.jsonl", _maze_rows())
    walker = _write(tmp_path / "walker.jsonl", walker_rows)
    text = write_report([maze, walker], tmp_path / "report").read_text()
    assert "| td3il | offline-il | 13.3 min (cpu) | 25.8 min (cpu@5) | 7h3m |" in text
    assert "| sqil | offline-il | 17.5 min | – |" in text  # one domain: no budget named
    other = [dict(walker_rows[0], draw=2, budget="cpu")]
    with pytest.raises(FbilError, match="several budgets of td3il"):
        write_report([maze, walker, _write(tmp_path / "w2.jsonl", other)], tmp_path / "r2")
    assert not (tmp_path / "r2").exists()
    mixed = _write(tmp_path / "mixed.jsonl", _maze_rows() + walker_rows)
    with pytest.raises(FbilError, match="mix domains"):
        write_report(mixed, tmp_path / "report")


def test_a_paper_figure_no_policy_can_reach_is_marked_and_left_out(tmp_path: Path) -> None:
    """Table 5's SMODICE return on reach_bottom_left_long (1 340.2) is above the task's
    1 000: the returns table marks it, and SMODICE is compared on the other tasks too."""
    smodice = {"reach_bottom_left_long": (-0.9, -1.1), "loop": (0.3, 0.5), "square": (0.2, 0.2)}
    rows = _maze_rows() + _rows("point_mass_maze", "smodice", smodice, (500.0,) * 6)
    text = write_report(_write(tmp_path / "maze.jsonl", rows), tmp_path / "report").read_text()
    assert "(1340.2†)" in text and "## Paper figures above a task's maximum return" in text
    # Paper on loop and square: (442.7 / 912.4 + 296.7 / 952.9) / 2; ours (40 + 20) / 2.
    paper = 100 * (442.7 / 912.4 + 296.7 / 952.9) / 2
    row = f"| smodice | reach_bottom_left_long: 1340.2 (1000) | -100.0 | {paper:.1f} | 30.0 |"
    assert row in text
    # Results on that task alone: nothing to compare the rest with, and no crash.
    alone = _rows("point_mass_maze", "smodice", {"reach_bottom_left_long": (-1.0,)}, (5.0,))
    only = write_report(_write(tmp_path / "only.jsonl", alone), tmp_path / "only").read_text()
    assert "| smodice | reach_bottom_left_long: 1340.2 (1000) | -100.0 | – | – |" in only
    # Without such a method in the results there is no such section.
    plain = write_report(_write(tmp_path / "plain.jsonl", _maze_rows()), tmp_path / "plain")
    assert "maximum return" not in plain.read_text()


def test_a_grid_run_with_two_training_seeds_is_averaged_per_draw(tmp_path: Path) -> None:
    """A second seed's lines (same tasks and draws) used to replace the first's: now each
    draw's score is the mean over its seeds, and the report shows each seed and the gap."""
    scores = {"loop": (0.2, 0.4), "square": (0.4, 0.6)}  # seed 0: draws 30 %, 50 %
    seed0 = _rows("point_mass_maze", "td3il", scores, (800.0,) * 4)
    seed1 = [{**r, "seed": 1, "score": r["score"] + 0.2} for r in seed0]  # 50 %, 70 %
    td3il = summarise([*seed0, *seed1])["settings"]["standard, K=1"]["td3il"]
    assert td3il["score"] == pytest.approx(0.5)  # draws 40 % and 60 %
    assert td3il["ci95"] == pytest.approx(1.96 * 0.1414214 / 2**0.5, rel=1e-5)  # over 2 draws
    assert (td3il["draws"], td3il["seeds"], td3il["jobs"]) == (2, 2, 8)
    assert td3il["seed_scores"] == pytest.approx({0: 0.4, 1: 0.6})
    one_seed = summarise(seed0)["settings"]["standard, K=1"]["td3il"]
    assert (one_seed["score"], one_seed["seeds"], one_seed["seed_scores"]) == (
        pytest.approx(0.4),
        1,
        {},
    )
    text = write_report(_write(tmp_path / "r.jsonl", [*seed0, *seed1]), tmp_path / "o")
    report = text.read_text()
    assert "| td3il | reward (0/1 labels) | 50.0 | 19.6 | 2 × 2 seeds | 65.1 |" in report
    assert "| td3il | seed 0: 40.0, seed 1: 60.0 | 20.0 | loop 20.0, square 20.0 |" in report
    assert td3il["task_seed_gaps"] == pytest.approx({"loop": 0.2, "square": 0.2})


def test_the_seed_gap_per_task_is_over_the_draws_every_seed_has() -> None:
    """Seed 1 ran only draw 0, where it is 30 points above seed 0 on loop and level on
    square: the gaps compare the seeds on that draw, not seed 0's mean over two draws."""
    seed0 = _rows(
        "point_mass_maze", "td3il", {"loop": (0.2, 0.9), "square": (0.5, 0.1)}, (800.0,) * 4
    )
    seed1 = [
        {**r, "seed": 1, "score": r["score"] + (0.3 if r["task"] == "loop" else 0.0)}
        for r in seed0
        if r["draw"] == 0
    ]
    td3il = summarise([*seed0, *seed1])["settings"]["standard, K=1"]["td3il"]
    assert td3il["task_seed_gaps"] == pytest.approx({"loop": 0.3, "square": 0.0})
    assert summarise(seed0)["settings"]["standard, K=1"]["td3il"]["task_seed_gaps"] == {}
