"""scripts/slim_results.py: only the lines the report draws keep their trajectory; every
other byte stays; bad input is one line and exit 2."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.script_module import load_script

slim = load_script("slim_results")


def _line(draw: int, k: int, demo_set: str = "standard") -> dict:
    row = {"task": "walk", "method": "erfb", "draw": draw, "k": k, "demo_set": demo_set}
    return {**row, "score": 0.5 + draw / 10, "trajectory": [[0.1, 0.2]] * 3}


def test_lines_the_report_does_not_draw_lose_their_trajectory(tmp_path: Path) -> None:
    rows = [_line(0, 1), _line(1, 1), _line(0, 10), _line(0, 1, "shifted")]
    path = tmp_path / "r.jsonl"
    path.write_text("".join(json.dumps(r) + "\n" for r in rows))
    first = path.read_text().splitlines()[0]
    assert slim.main([str(path)]) == 0
    lines = path.read_text().splitlines()
    assert lines[0] == first  # drawn: byte for byte
    assert ["trajectory" in json.loads(x) for x in lines] == [True, False, False, False]
    assert [json.loads(x)["score"] for x in lines] == [r["score"] for r in rows]


@pytest.mark.parametrize("content", [None, '{"task": "walk"}\nnot json\n'])
def test_a_missing_or_damaged_file_is_one_line_and_exit_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], content: str | None
) -> None:
    path = tmp_path / "r.jsonl"
    if content is not None:
        path.write_text(content)
    assert slim.main([str(path)]) == 2
    assert len(capsys.readouterr().err.strip().splitlines()) == 1
    assert path.exists() == (content is not None) and not list(tmp_path.glob(".*"))
