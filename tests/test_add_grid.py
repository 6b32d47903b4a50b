"""scripts/add_grid.py: a baseline's grid goes into a results file only whole, from one
data sample and one budget, and replaces the method's old lines rather than mixing."""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

import pytest

from fbil.envs.registry import get_domain
from fbil.errors import FbilError
from tests.script_module import load_script

add_grid = load_script("add_grid")
TASKS = list(get_domain("point_mass_maze").tasks)


def _line(method: str, task: str, draw: int, digest: str | None = "d1", **kw: Any) -> dict:
    row = {
        "domain": "point_mass_maze",
        "method": method,
        "task": task,
        "draw": draw,
        "k": 1,
        "demo_set": "standard",
        "budget": "cpu",
        "data_digest": digest,
        "score": 0.25 + 0.5 * draw,
        "seconds": 100.0 + draw,
    }
    return {**row, **kw}


def _write(path: Path, rows: list[dict]) -> Path:
    path.write_text("".join(json.dumps(r) + "\n" for r in rows))
    return path


def _grid(method: str = "smodice", **kw: Any) -> list[dict]:
    return [_line(method, t, d, **kw) for t in TASKS for d in range(2)]


def test_a_complete_grid_replaces_the_methods_old_lines(tmp_path: Path) -> None:
    other = [_line("bc", t, 0) for t in TASKS]
    results = _write(tmp_path / "baselines.jsonl", [*other, *_grid(digest=None, budget="old")])
    before = results.read_text().splitlines()
    grid = _write(tmp_path / "a.jsonl", _grid()[:6])
    grid_b = _write(tmp_path / "b.jsonl", _grid()[6:])
    moved = tmp_path / "old.jsonl"
    out = add_grid.add_grid(results, [grid, grid_b], moved)
    after = results.read_text().splitlines()
    assert after[: len(other)] == before[: len(other)]  # other methods' lines byte for byte
    assert [json.loads(t) for t in after[len(other) :]] == _grid()
    assert moved.read_text().splitlines() == before[len(other) :]
    # draw means 25 % and 75 %: their mean, both draws, the median of 100 s and 101 s
    assert "score 50.0 % (draw means 25.0, 75.0), median 100 s" in out
    assert "16 old lines moved" in out


@pytest.mark.parametrize(
    "rows, words",
    [
        (_grid()[:-1], f"missing [('{TASKS[-1]}', 1)]"),
        ([*_grid(), _grid()[0]], "more than once"),
        ([*_grid()[:-1], _line("smodice", TASKS[-1], 1, digest="d2")], "data_digest"),
        ([*_grid()[:-1], _line("smodice", TASKS[-1], 1, budget="cpu@2")], "budget"),
        (_grid(digest=None), "no data_digest"),
        ([], "no lines"),
    ],
)
def test_anything_but_one_complete_grid_is_refused(
    tmp_path: Path, rows: list[dict], words: str
) -> None:
    results = _write(tmp_path / "baselines.jsonl", [_line("bc", "loop", 0)])
    before = results.read_text()
    with pytest.raises(FbilError, match=re.escape(words)):
        add_grid.add_grid(results, [_write(tmp_path / "g.jsonl", rows)], None)
    assert results.read_text() == before


def test_a_method_that_trains_on_no_data_needs_no_data_digest(tmp_path: Path) -> None:
    results = _write(tmp_path / "baselines.jsonl", [])
    grid = _write(tmp_path / "g.jsonl", _grid("bc", digest=None))
    assert "score 50.0 %" in add_grid.add_grid(results, [grid], None)
    assert len(results.read_text().splitlines()) == 2 * len(TASKS)


def test_old_lines_of_the_method_need_a_place_to_go(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    results = _write(tmp_path / "baselines.jsonl", _grid(digest="d0"))
    before = results.read_text()
    grid = _write(tmp_path / "g.jsonl", _grid())
    assert add_grid.main([str(results), str(grid)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "already holds 16 smodice lines; pass --replaced-to" in err[0]
    taken = _write(tmp_path / "taken.jsonl", [])
    assert add_grid.main([str(results), str(grid), "--replaced-to", str(taken)]) == 2
    assert results.read_text() == before


def test_a_second_seed_is_added_beside_the_first_and_scored_with_it(tmp_path: Path) -> None:
    first = _grid(seed=0)
    results = _write(tmp_path / "baselines.jsonl", [_line("bc", "loop", 0), *first])
    second = [{**r, "seed": 1, "score": r["score"] + 0.1} for r in first]
    out = add_grid.add_grid(results, [_write(tmp_path / "s1.jsonl", second)], None, add_seed=True)
    after = [json.loads(t) for t in results.read_text().splitlines()]
    assert after == [_line("bc", "loop", 0), *first, *second]  # nothing moved, nothing lost
    # seed 1's own draw means 35 % and 85 %; over both seeds 30 % and 80 %, mean 55 %
    assert "seed 1; score 60.0 % (draw means 35.0, 85.0)" in out
    assert "over seeds 0, 1: score 55.0 % (draw means 30.0, 80.0)" in out


def test_a_second_seed_replaces_only_its_own_seed_and_needs_the_same_grid(
    tmp_path: Path,
) -> None:
    results = _write(tmp_path / "baselines.jsonl", [*_grid(seed=0), *_grid(seed=1)])
    again = _write(tmp_path / "again.jsonl", _grid(seed=1, score=0.0))
    moved = tmp_path / "moved.jsonl"
    add_grid.add_grid(results, [again], moved, add_seed=True)
    assert [json.loads(t) for t in moved.read_text().splitlines()] == _grid(seed=1)
    kept = [json.loads(t) for t in results.read_text().splitlines()]
    assert kept == [*_grid(seed=0), *_grid(seed=1, score=0.0)]
    before = results.read_text()
    for other in ({"budget": "cpu@2"}, {"digest": "d9"}):
        grid = _write(tmp_path / "g.jsonl", _grid(seed=2, **other))
        with pytest.raises(FbilError, match="add a seed only to a grid of the same budget"):
            add_grid.add_grid(results, [grid], None, add_seed=True)
    assert results.read_text() == before


def test_a_grid_of_two_seeds_at_once_is_refused(tmp_path: Path) -> None:
    rows = [*_grid(seed=0)[:-1], _line("smodice", TASKS[-1], 1, seed=1)]
    with pytest.raises(FbilError, match="several seed values"):
        add_grid.add_grid(tmp_path / "r.jsonl", [_write(tmp_path / "g.jsonl", rows)], None)
