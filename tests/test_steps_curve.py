"""scripts/steps_curve.sh refuses bad input with one line and exit 2 before it runs anything."""

from __future__ import annotations

import subprocess
from pathlib import Path

SCRIPT = Path(__file__).resolve().parents[1] / "scripts" / "steps_curve.sh"


def _run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(["bash", str(SCRIPT), *args], capture_output=True, text=True)


def test_no_snapshot_folders_is_one_line() -> None:
    res = _run("datasets/point_mass_maze/rnd")
    assert res.returncode == 2
    assert res.stderr.strip().splitlines() == [
        "error: no snapshot folders given; usage: scripts/steps_curve.sh DATA SNAP..."
    ]


def test_a_folder_without_a_model_is_one_line(tmp_path: Path) -> None:
    res = _run("datasets/point_mass_maze/rnd", str(tmp_path))
    assert res.returncode == 2
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and "has no model.safetensors" in lines[0]
    assert not list(tmp_path.iterdir())  # nothing written
