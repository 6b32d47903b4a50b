"""scripts/baseline_queue.py: which baseline jobs are committed, carried or left, and what
the rest costs by the method's own measured lines."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from fbil.envs.registry import get_domain
from tests.script_module import load_script

queue = load_script("baseline_queue")
TASKS = list(get_domain("cheetah").tasks)
AUTO = "cpu@6,td3.clamp_values=true"  # cheetah's measured budget of td3il


def _line(task: str, draw: int, budget: str = AUTO, seconds: float = 600.0, **kw: Any) -> dict:
    row = {"domain": "cheetah", "method": "td3il", "task": task, "draw": draw, "k": 1}
    return {**row, "demo_set": "standard", "budget": budget, "seconds": seconds, **kw}


def test_jobs_are_committed_carried_or_left_and_cost_their_median() -> None:
    committed = [_line(TASKS[0], 0, seconds=1200.0)]
    others = [
        _line(TASKS[0], 1, seconds=1800.0),
        _line(TASKS[1], 0, seconds=2400.0),
        _line(TASKS[1], 1, budget="cpu"),  # another budget: neither carried nor timed
        _line(TASKS[2], 0, k=10),  # not the K = 1 standard grid
        _line(TASKS[2], 1, method="oril"),
    ]
    row = queue.queue_row("cheetah", "td3il", committed, others, draws=2)
    assert row["budget"] == AUTO
    assert (row["jobs"], row["committed"], row["carried"], row["left"]) == (8, 1, 2, 5)
    assert row["minutes_per_job"] == pytest.approx(30.0)  # median of 20, 30 and 40 min
    assert row["core_hours_left"] == pytest.approx(2.5)


def test_without_lines_the_projection_at_the_same_budget_is_used() -> None:
    entry: dict[str, Any] = {"budget": AUTO, "projected_seconds": 3600.0}
    timing = {"machine": "CPU X, AVX2", "baselines": {"td3il": entry}}
    row = queue.queue_row("cheetah", "td3il", [], [], draws=2, timing=timing)
    assert row["minutes_per_job"] == pytest.approx(60.0) and row["core_hours_left"] == 8.0
    assert row["machines"] == ["CPU X (projected)"]
    entry["budget"] = "cpu"  # made at another budget: no figure
    row = queue.queue_row("cheetah", "td3il", [], [], draws=2, timing=timing)
    assert row["minutes_per_job"] is None and "?" in queue.table([row])


def test_an_unknown_domain_is_one_line_and_exit_2(capsys: pytest.CaptureFixture) -> None:
    assert queue.main(["--domains", "cheeta"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error: ") and "cheeta" in err and "\n" not in err


def test_the_json_file_is_written_whole_or_refused_in_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture
) -> None:
    out = tmp_path / "queue.json"
    assert queue.main(["--domains", "cheetah", "--json", str(out)]) == 0
    rows = json.loads(out.read_text())
    assert {r["method"] for r in rows} >= {"td3il", "goal_td3"}
    assert all(r["domain"] == "cheetah" and r["jobs"] == 8 for r in rows)
    capsys.readouterr()
    # a file where a folder should be: cannot be written
    assert queue.main(["--domains", "cheetah", "--json", str(out / "q.json")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error: cannot write") and "\n" not in err
