"""The command line as a user runs it: a real subprocess, real files."""

import json
import subprocess
import sys
from pathlib import Path

import pytest

from tests.envs.test_registry import EXPECTED


def fbil(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "fbil", *args], capture_output=True, text=True, timeout=300
    )


def test_tasks_json_lists_the_21_tasks_with_sizes() -> None:
    res = fbil("tasks", "--json")
    assert res.returncode == 0, res.stderr
    domains = json.loads(res.stdout)["domains"]
    assert {d: (v["obs_dim"], v["act_dim"], v["tasks"]) for d, v in domains.items()} == EXPECTED


def test_tasks_table_is_readable() -> None:
    res = fbil("tasks")
    assert res.returncode == 0 and "21 tasks" in res.stdout and "fast_slow" in res.stdout


@pytest.mark.parametrize(
    "args, names",
    [
        (["render", "humanoid", "run", "--out", "x.png"], "point_mass_maze, walker"),
        (["render", "walker", "backflip", "--out", "x.png"], "stand, walk, run, flip, spin"),
        (["render", "walker", "walk", "--policy", "expert", "--out", "x.png"], "random"),
        (["render", "walker", "walk", "--out", "x.bmp"], ".gif"),
    ],
)
def test_bad_names_give_one_line_and_exit_2(args: list[str], names: str, tmp_path: Path) -> None:
    res = fbil(*args)
    assert res.returncode == 2
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("fbil: error:") and names in lines[0]
    assert "Traceback" not in res.stderr


def test_render_maze_and_locomotion(tmp_path: Path) -> None:
    maze = tmp_path / "maze.png"
    res = fbil(
        "render", "point_mass_maze", "square", "--out", str(maze), "--steps", "100", "--json"
    )
    assert res.returncode == 0, res.stderr
    payload = json.loads(res.stdout)
    assert payload["out"] == str(maze) and len(payload["returns"]) == 5
    assert maze.read_bytes()[:4] == b"\x89PNG"
    strip = tmp_path / "cheetah.png"
    res = fbil("render", "cheetah", "run", "--out", str(strip), "--steps", "20", "--frames", "3")
    assert res.returncode == 0, res.stderr
    assert strip.stat().st_size > 1000


FIXTURE = Path(__file__).parent / "fixtures" / "exorl" / "point_mass_maze" / "rnd"


def test_dataset_info_reports_coverage_and_plots(tmp_path: Path) -> None:
    import shutil

    data = tmp_path / "maze"
    shutil.copytree(FIXTURE, data)
    plot = tmp_path / "cov.png"
    res = fbil("dataset-info", str(data), "--plot", str(plot), "--json")
    assert res.returncode == 0, res.stderr
    info = json.loads(res.stdout)
    assert info["episodes"] == 4 and info["transitions"] == 4000
    cov = info["coverage"]
    assert 0 < cov["grid_fraction"] <= 1 and "top_left" in cov["rooms_visited"]
    assert plot.read_bytes()[:4] == b"\x89PNG"


def test_dataset_merge_from_the_command_line(tmp_path: Path) -> None:
    out = tmp_path / "both"
    res = fbil("dataset-merge", str(FIXTURE), str(FIXTURE), "--out", str(out), "--json")
    assert res.returncode == 0, res.stderr
    manifest = json.loads(res.stdout)
    assert manifest["episodes"] == 8 and manifest["command"].startswith("fbil dataset-merge")
    info = json.loads(fbil("dataset-info", str(out), "--json").stdout)
    assert info["episodes"] == 8 and info["transitions"] == 8000


def test_dataset_errors_are_one_line(tmp_path: Path) -> None:
    import shutil

    data = tmp_path / "maze"
    shutil.copytree(FIXTURE, data)
    bad = sorted((data / "buffer").glob("*.npz"))[2]
    bad.write_bytes(bad.read_bytes()[:500])
    for args, expected in [
        (["dataset-info", str(tmp_path / "nothing")], "no dataset at"),
        (["dataset-info", str(data)], bad.name),
        (["dataset-info", str(FIXTURE), "--domain", "walker"], "not walker"),
        (["dataset-merge", str(FIXTURE), str(data), "--out", str(data)], "already exists"),
        (["dataset-oversample", str(FIXTURE), "--out", str(tmp_path / "o")], "changes room"),
        (["collect", "humanoid", "--episodes", "1", "--out", str(tmp_path / "h")], "valid domains"),
    ]:
        res = fbil(*args)
        lines = res.stderr.strip().splitlines()
        assert res.returncode == 2 and len(lines) == 1 and expected in lines[0], res.stderr
