"""`fbil demo` end to end on the committed models and demonstrations (maze, cheetah)."""

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ARTIFACTS = Path(__file__).resolve().parents[2] / "artifacts"


def run(*args: str, env: dict[str, str] | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "fbil", "demo", *args],
        capture_output=True,
        text=True,
        timeout=600,
        env={**os.environ, **(env or {})},
    )


def test_demo_imitates_and_draws_on_the_committed_artifacts(tmp_path: Path) -> None:
    res = run("--episodes", "1", "--methods", "erfb,goalfb", "--out", str(tmp_path))
    assert res.returncode == 0, res.stderr
    lines = res.stdout.splitlines()
    assert any(line.startswith("expert return:") for line in lines)
    for method in ("erfb", "goalfb"):
        row = next(line for line in lines if line.startswith(method))
        assert row.rstrip().endswith("%")
    assert (tmp_path / "demo_loop.png").stat().st_size > 5000


def test_demo_on_a_locomotion_domain_draws_frames_of_its_default_task(tmp_path: Path) -> None:
    res = run(
        "--domain", "cheetah", "--episodes", "1", "--methods", "goalfb", "--out", str(tmp_path)
    )
    assert res.returncode == 0, res.stderr
    assert "cheetah/walk" in res.stdout  # the domain's demo task (its hooks' demo_task)
    row = next(line for line in res.stdout.splitlines() if line.startswith("goalfb"))
    assert row.rstrip().endswith("%")
    assert (tmp_path / "demo_walk.png").stat().st_size > 20000  # rows of rendered frames


def test_a_domain_without_shipped_artifacts_names_those_that_have_them(tmp_path: Path) -> None:
    root = tmp_path / "artifacts"
    for part in ("models/point_mass_maze", "demos/point_mass_maze"):
        shutil.copytree(ARTIFACTS / part, root / part)
    out = tmp_path / "figures"
    res = run("--domain", "walker", "--out", str(out), env={"FBIL_ARTIFACTS": str(root)})
    lines = res.stderr.strip().splitlines()
    assert res.returncode == 2 and len(lines) == 1, res.stderr
    assert "no committed demos for walker" in lines[0] and "--domain point_mass_maze" in lines[0]
    assert not out.exists()


def test_a_corrupted_artifact_is_named_with_its_fix(tmp_path: Path) -> None:
    root = tmp_path / "artifacts"
    for part in ("models/point_mass_maze", "demos/point_mass_maze"):
        shutil.copytree(ARTIFACTS / part, root / part)
    demo = root / "demos/point_mass_maze/loop.npz"
    data = bytearray(demo.read_bytes())
    data[len(data) // 2] ^= 0xFF
    demo.write_bytes(bytes(data))
    res = run("--episodes", "1", "--methods", "erfb", env={"FBIL_ARTIFACTS": str(root)})
    assert res.returncode != 0
    message = res.stderr.strip().splitlines()
    assert len(message) == 1 and "loop.npz" in message[0] and "regenerate" in message[0]
    assert "Traceback" not in res.stderr


def test_the_default_figure_folder_is_gitignored() -> None:
    from fbil.evaluation.demo import DEFAULT_OUT

    repo = ARTIFACTS.parent
    if not (repo / ".git").exists():
        pytest.skip("not a git checkout")
    res = subprocess.run(
        ["git", "-C", str(repo), "check-ignore", "-q", f"{DEFAULT_OUT}/demo_loop.png"],
        capture_output=True,
    )
    assert res.returncode == 0, f"{DEFAULT_OUT} is not gitignored"


def test_unknown_tasks_are_refused_before_any_work(tmp_path: Path) -> None:
    res = run("--tasks", "loop,nowhere", "--out", str(tmp_path / "figures"))
    lines = res.stderr.strip().splitlines()
    assert res.returncode == 2 and len(lines) == 1 and "'nowhere'" in lines[0], res.stderr
    assert "available: " in lines[0] and "loop" in lines[0]
    assert not (tmp_path / "figures").exists()  # loop was not run first
